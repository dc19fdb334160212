//! The joint least-squares solve of a calibration: residuals and their derivatives, the
//! block-sparse normal equations, the Schur complement over the attitude blocks (faer), the
//! Levenberg–Marquardt loop and the covariance of the intrinsics.

use faer::linalg::solvers::DenseSolveCore;
use faer::prelude::Solve;
use faer::Mat;
use nalgebra::{Matrix3, Rotation3, Vector3};

use super::{CalibrationFrame, Intrinsic};
use crate::error::{Error, Result};
use crate::geometry::Camera;

pub(super) fn as_weights(masks: &[Vec<bool>]) -> Vec<Vec<f64>> {
    masks
        .iter()
        .map(|m| m.iter().map(|&k| f64::from(u8::from(k))).collect())
        .collect()
}

#[derive(Debug, Clone)]
pub(super) struct State {
    pub(super) camera: Camera,
    pub(super) attitudes: Vec<Rotation3<f64>>,
}

pub(super) fn residuals(frames: &[CalibrationFrame], state: &State) -> Vec<Vec<[f64; 2]>> {
    frames
        .iter()
        .zip(&state.attitudes)
        .map(|(f, r)| {
            f.pixels
                .iter()
                .zip(&f.stars)
                .map(|(p, s)| match state.camera.cam_to_pixel(&(r * s)) {
                    Some((x, y)) => [p[0] - x, p[1] - y],
                    None => [f64::INFINITY, f64::INFINITY],
                })
                .collect()
        })
        .collect()
}

/// One match's predicted pixel and its derivatives: 2×3 by the attitude's rotation vector and
/// 2×n by the fitted intrinsics (rows x, y); `None` behind the camera.
pub(super) fn linearised(
    camera: &Camera,
    w: &Vector3<f64>,
    intrinsics: &[Intrinsic],
    shared: &mut [[f64; 2]],
) -> Option<([f64; 2], [[f64; 3]; 2])> {
    if w.z <= 1e-9 {
        return None;
    }
    let (u, v) = (w.x / w.z, w.y / w.z);
    let ((ud, vd), jd) = camera.distort(u, v);
    let f = camera.focal_length_px;
    let pred = [
        camera.principal_point_px[0] + f * ud,
        camera.principal_point_px[1] + f * vd,
    ];
    // ∂(u, v)/∂w, then ∂w/∂δ = −[w]× for the perturbation w → w + δ × w.
    let iz = 1.0 / w.z;
    let duv = [[iz, 0.0, -u * iz], [0.0, iz, -v * iz]];
    let dw = Matrix3::new(0.0, w.z, -w.y, -w.z, 0.0, w.x, w.y, -w.x, 0.0);
    let mut att = [[0.0; 3]; 2];
    for (row, att_row) in att.iter_mut().enumerate() {
        for (col, slot) in att_row.iter_mut().enumerate() {
            let mut acc = 0.0;
            for k in 0..2 {
                let jk = jd[row][k];
                for m in 0..3 {
                    acc += jk * duv[k][m] * dw[(m, col)];
                }
            }
            *slot = f * acc;
        }
    }
    let r2 = u * u + v * v;
    for (slot, p) in shared.iter_mut().zip(intrinsics) {
        *slot = match p {
            Intrinsic::FocalLength => [ud, vd],
            Intrinsic::Cx => [1.0, 0.0],
            Intrinsic::Cy => [0.0, 1.0],
            Intrinsic::K1 => [f * u * r2, f * v * r2],
            Intrinsic::K2 => [f * u * r2 * r2, f * v * r2 * r2],
            Intrinsic::K3 => [f * u * r2 * r2 * r2, f * v * r2 * r2 * r2],
            Intrinsic::P1 => [f * 2.0 * u * v, f * (r2 + 2.0 * v * v)],
            Intrinsic::P2 => [f * (r2 + 2.0 * u * u), f * 2.0 * u * v],
        };
    }
    Some((pred, att))
}

/// The normal equations of one state: per frame `Aᵢ` (3×3), `Bᵢ` (3×n), `gᵢ`; shared `C`, `g`.
struct Normal {
    a: Vec<Matrix3<f64>>,
    b: Vec<Vec<[f64; 3]>>,
    g: Vec<Vector3<f64>>,
    c: Vec<f64>,
    gs: Vec<f64>,
    cost: f64,
}

fn normal(
    frames: &[CalibrationFrame],
    weights: &[Vec<f64>],
    state: &State,
    intrinsics: &[Intrinsic],
) -> Option<Normal> {
    let n = intrinsics.len();
    let mut out = Normal {
        a: Vec::with_capacity(frames.len()),
        b: Vec::with_capacity(frames.len()),
        g: Vec::with_capacity(frames.len()),
        c: vec![0.0; n * n],
        gs: vec![0.0; n],
        cost: 0.0,
    };
    let mut js = vec![[0.0; 2]; n];
    for ((f, weight), r) in frames.iter().zip(weights).zip(&state.attitudes) {
        let mut a = Matrix3::zeros();
        let mut b = vec![[0.0; 3]; n];
        let mut g = Vector3::zeros();
        for ((p, s), &wt) in f
            .pixels
            .iter()
            .zip(&f.stars)
            .zip(weight)
            .filter(|(_, &k)| k > 0.0)
        {
            let (pred, mut ja) = linearised(&state.camera, &(r * s), intrinsics, &mut js)?;
            // A weight scales the match's residuals and rows by its square root.
            let sw = wt.sqrt();
            let res = [sw * (p[0] - pred[0]), sw * (p[1] - pred[1])];
            for row in &mut ja {
                for v in row.iter_mut() {
                    *v *= sw;
                }
            }
            for j in js.iter_mut() {
                j[0] *= sw;
                j[1] *= sw;
            }
            out.cost += res[0] * res[0] + res[1] * res[1];
            for k in 0..2 {
                for i in 0..3 {
                    g[i] += ja[k][i] * res[k];
                    for j in 0..3 {
                        a[(i, j)] += ja[k][i] * ja[k][j];
                    }
                    for (bj, jsj) in b.iter_mut().zip(&js) {
                        bj[i] += ja[k][i] * jsj[k];
                    }
                }
                for (i, jsi) in js.iter().enumerate() {
                    out.gs[i] += jsi[k] * res[k];
                    // C is symmetric: its upper triangle here, the lower one mirrored below.
                    for (j, jsj) in js.iter().enumerate().skip(i) {
                        out.c[i * n + j] += jsi[k] * jsj[k];
                    }
                }
            }
        }
        out.a.push(a);
        out.b.push(b);
        out.g.push(g);
    }
    for i in 0..n {
        for j in 0..i {
            out.c[i * n + j] = out.c[j * n + i];
        }
    }
    Some(out)
}

/// The shared system `S`, its right-hand side, and each frame's damped `Aᵢ⁻¹`.
type Reduced = (Mat<f64>, Vec<f64>, Vec<Matrix3<f64>>);

/// The Schur complement `S = C − Σ Bᵢᵀ Aᵢ⁻¹ Bᵢ` and its right-hand side, with the attitude
/// blocks damped by `lambda` (Marquardt's scaling); `None` when a block is singular.
fn schur(ne: &Normal, lambda: f64) -> Option<Reduced> {
    let n = ne.gs.len();
    let mut s = Mat::<f64>::from_fn(n, n, |i, j| {
        let v = ne.c[i * n + j];
        if i == j {
            v * (1.0 + lambda)
        } else {
            v
        }
    });
    let mut rhs = ne.gs.clone();
    let mut inverses = Vec::with_capacity(ne.a.len());
    for ((a, b), g) in ne.a.iter().zip(&ne.b).zip(&ne.g) {
        let mut damped = *a;
        for i in 0..3 {
            damped[(i, i)] *= 1.0 + lambda;
        }
        let inv = damped.try_inverse()?;
        // Aᵢ⁻¹ Bᵢ column by column, then subtract Bᵢᵀ (Aᵢ⁻¹ Bᵢ) and Bᵢᵀ (Aᵢ⁻¹ gᵢ).
        let ainv_b: Vec<Vector3<f64>> = b.iter().map(|bj| inv * Vector3::from(*bj)).collect();
        let ainv_g = inv * g;
        for i in 0..n {
            let bi = Vector3::from(b[i]);
            rhs[i] -= bi.dot(&ainv_g);
            for (j, col) in ainv_b.iter().enumerate() {
                s[(i, j)] -= bi.dot(col);
            }
        }
        inverses.push(inv);
    }
    Some((s, rhs, inverses))
}

/// Solve `S x = rhs` (Cholesky, or LU where rounding leaves S indefinite).
fn solve_shared(s: &Mat<f64>, rhs: &[f64]) -> Option<Vec<f64>> {
    let n = rhs.len();
    if n == 0 {
        return Some(Vec::new());
    }
    let b = Mat::<f64>::from_fn(n, 1, |i, _| rhs[i]);
    let x = match s.llt(faer::Side::Lower) {
        Ok(llt) => llt.solve(&b),
        Err(_) => s.partial_piv_lu().solve(&b),
    };
    let out: Vec<f64> = (0..n).map(|i| x[(i, 0)]).collect();
    out.iter().all(|v| v.is_finite()).then_some(out)
}

pub(super) struct Fit {
    pub(super) state: State,
    pub(super) iterations: usize,
}

/// Levenberg–Marquardt over the attitudes and the given intrinsics, each step through the
/// Schur complement.
pub(super) fn fit(
    frames: &[CalibrationFrame],
    weights: &[Vec<f64>],
    start: State,
    intrinsics: &[Intrinsic],
    max_iterations: usize,
) -> Result<Fit> {
    let failed = || Error::invalid_input("calibration failed: stars behind the camera");
    let mut state = start;
    let mut ne = normal(frames, weights, &state, intrinsics).ok_or_else(failed)?;
    let mut lambda = 1e-4;
    let mut iterations = 0;
    while iterations < max_iterations && ne.cost > 0.0 {
        iterations += 1;
        let step = schur(&ne, lambda).and_then(|(s, rhs, inv)| {
            let ds = solve_shared(&s, &rhs)?;
            Some((ds, inv))
        });
        let Some((ds, inverses)) = step else {
            lambda *= 10.0;
            if lambda > 1e12 {
                break;
            }
            continue;
        };
        let mut trial = state.clone();
        for (p, d) in intrinsics.iter().zip(&ds) {
            let v = p.value(&trial.camera) + d;
            p.set(&mut trial.camera, v);
        }
        let mut largest = 0f64;
        for (i, inv) in inverses.iter().enumerate() {
            let mut rhs = ne.g[i];
            for (bj, d) in ne.b[i].iter().zip(&ds) {
                rhs -= Vector3::from(*bj) * *d;
            }
            let dtheta = inv * rhs;
            largest = largest.max(dtheta.amax());
            trial.attitudes[i] = Rotation3::new(dtheta) * trial.attitudes[i];
        }
        let plausible =
            trial.camera.focal_length_px > 0.0 && trial.camera.focal_length_px.is_finite();
        match plausible
            .then(|| normal(frames, weights, &trial, intrinsics))
            .flatten()
        {
            Some(next) if next.cost <= ne.cost => {
                // Converged once a step changes the cost by a part in 10¹⁰ (far below what the
                // covariance resolves) or turns no frame by more than 10⁻¹⁰ rad.
                let relative = (ne.cost - next.cost) / ne.cost.max(f64::MIN_POSITIVE);
                let small = largest < 1e-10;
                state = trial;
                ne = next;
                lambda = (lambda / 3.0).max(1e-12);
                if small || relative < 1e-10 {
                    break;
                }
            }
            _ => {
                lambda *= 4.0;
                if lambda > 1e12 {
                    break;
                }
            }
        }
    }
    Ok(Fit { state, iterations })
}

/// `σ² S⁻¹` at the solution, undamped; NaN where S is singular.
pub(super) fn covariance(
    frames: &[CalibrationFrame],
    masks: &[Vec<bool>],
    state: &State,
    intrinsics: &[Intrinsic],
    n_params: usize,
) -> Vec<f64> {
    let n = intrinsics.len();
    let nan = vec![f64::NAN; n * n];
    let Some(ne) = normal(frames, &as_weights(masks), state, intrinsics) else {
        return nan;
    };
    let Some((s, _, _)) = schur(&ne, 0.0) else {
        return nan;
    };
    let kept: usize = masks.iter().flatten().filter(|&&k| k).count();
    let dof = (2 * kept).saturating_sub(n_params).max(1);
    let sigma2 = ne.cost / dof as f64;
    let Ok(llt) = s.llt(faer::Side::Lower) else {
        return nan;
    };
    let inv = llt.inverse();
    (0..n * n).map(|k| sigma2 * inv[(k / n, k % n)]).collect()
}
