//! Attitude from matched directions: Wahba's problem solved by SVD (Markley 1988).
//!
//! Find the rotation `R` minimising `Σ wᵢ |bᵢ − R rᵢ|²` for camera-frame directions `bᵢ` and
//! catalogue directions `rᵢ`. With `B = Σ wᵢ bᵢ rᵢᵀ = U S Vᵀ`, the optimum is
//! `R = U diag(1, 1, det U · det V) Vᵀ`, a proper rotation even for noisy or planar data.

use nalgebra::{Matrix3, Rotation3, Vector3};

/// Rotation ICRS → camera that best maps `ref_icrs[i]` onto `obs_cam[i]` (equal weights).
///
/// Returns `None` with fewer than two pairs or when the directions do not fix a rotation
/// (all parallel).
pub fn wahba_svd(obs_cam: &[Vector3<f64>], ref_icrs: &[Vector3<f64>]) -> Option<Rotation3<f64>> {
    if obs_cam.len() < 2 || obs_cam.len() != ref_icrs.len() {
        return None;
    }
    let mut b = Matrix3::zeros();
    for (o, r) in obs_cam.iter().zip(ref_icrs) {
        b += o * r.transpose();
    }
    let svd = b.svd(true, true);
    let (u, v_t) = (svd.u?, svd.v_t?);
    // Two non-zero singular values are needed for a unique rotation.
    let mut s = svd.singular_values;
    s.as_mut_slice().sort_unstable_by(|a, b| b.total_cmp(a));
    if s[1].is_nan() || s[1] <= 1e-12 * s[0].max(1e-300) {
        return None;
    }
    let d = (u.determinant() * v_t.determinant()).signum();
    let m = u * Matrix3::from_diagonal(&Vector3::new(1.0, 1.0, d)) * v_t;
    Some(Rotation3::from_matrix_unchecked(m))
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::Unit;

    #[test]
    fn recovers_a_rotation_exactly() {
        let r = Rotation3::from_axis_angle(&Unit::new_normalize(Vector3::new(0.3, -1.0, 2.0)), 2.1);
        let refs: Vec<_> = [
            Vector3::new(1.0, 0.2, 0.1),
            Vector3::new(0.1, 1.0, 0.0),
            Vector3::new(0.3, 0.3, 1.0),
        ]
        .iter()
        .map(|v| v.normalize())
        .collect();
        let obs: Vec<_> = refs.iter().map(|v| r * v).collect();
        let est = wahba_svd(&obs, &refs).unwrap();
        assert!((est.matrix() - r.matrix()).norm() < 1e-12);
        assert!(wahba_svd(&obs[..1], &refs[..1]).is_none());
        assert!(wahba_svd(&[obs[0], obs[0]], &[refs[0], refs[0]]).is_none());
    }
}
