//! The focal check of a verified solution (see [`scale`]): searches with the camera its
//! residuals imply, and the attitude and residuals of a solution's matches under a camera.

use super::*;

impl Solver {
    /// The focal check (see [`scale`]): while a verified solution's residuals show the focal
    /// length (or the radial distortion) off, search the frame again with the camera they imply,
    /// at most [`scale::FOCAL_RETRIES`] times, keeping a new solution that matches at least as
    /// many centroids (more, for a distortion error short of significance: see
    /// [`scale::K1_TRY_SIGMAS`]). Within the configured timeout only.
    pub(crate) fn check_focal(&self, call: Call<'_>, id: &mut Identification) -> Result<()> {
        let (centroids, _, camera, config, start) = call.parts();
        let vectors = self.catalog.vectors();
        let mut cam = *camera;
        // The camera's errors that the solution kept shows (`id` under `cam`).
        let mut err = scale::camera_error(centroids, &cam, id, vectors);
        for _ in 0..scale::FOCAL_RETRIES {
            let Some(e) = err else { break };
            let Some(((a, b), strict)) = e.correction() else {
                break;
            };
            // A scale and a radial term fitted together to the centre of a field whose edges
            // went unmatched are confounded: where the joint correction is tried, the scale
            // alone is tried too, and the camera that names more spots kept.
            let mut corrections = vec![(a, b, strict)];
            if b != 0.0 && scale::significant(e.scale) {
                corrections.push((e.scale.0, 0.0, false));
            }
            let mut best: Option<(Camera, Identification, f64)> = None;
            for (a, b, strict) in corrections {
                if config.timeout.is_some_and(|t| start.elapsed() >= t) {
                    break;
                }
                let mut trial = cam;
                trial.focal_length_px *= 1.0 + a;
                if b != 0.0 {
                    let Ok(t) = trial.with_k1(cam.k1 + b) else {
                        continue;
                    };
                    trial = t;
                }
                let again = self.search_frame(call.with_camera(&trial))?;
                let enough = again.verified && again.matched >= id.matched + usize::from(strict);
                if enough
                    && best
                        .as_ref()
                        .is_none_or(|(_, b, _)| again.matched > b.matched)
                {
                    best = Some((trial, again, b));
                }
            }
            let Some((trial, again, b)) = best else { break };
            let k1_corrected = id.k1.is_some() || b != 0.0;
            (cam, *id) = (trial, again);
            id.focal_length_px = Some(cam.focal_length_px);
            id.k1 = k1_corrected.then_some(cam.k1);
            err = scale::camera_error(centroids, &cam, id, vectors);
        }
        // What the final matches still show (below the search's threshold) refines the camera
        // found: the attitude refitted and the residuals recomputed with it, the matches kept.
        if let (Some(_), Some(e)) = (id.focal_length_px, err) {
            let ((a, b), se) = e.refinement(id.k1.is_some());
            cam.focal_length_px *= 1.0 + a;
            if let Ok(t) = cam.with_k1(cam.k1 + b) {
                cam = t;
            }
            self.refit_matches(centroids, &cam, id);
            id.focal_length_px = Some(cam.focal_length_px);
            id.focal_sigma_px = se * cam.focal_length_px;
            id.k1 = id.k1.map(|_| cam.k1);
            // The refined camera may name spots the last search's could not (the edges of a
            // field whose scale the corrections approached from one side): kept if it does.
            let in_time = config.timeout.is_none_or(|t| start.elapsed() < t);
            if in_time && id.matched < centroids.len() {
                let again = self.search_frame(call.with_camera(&cam))?;
                if again.verified && again.matched > id.matched {
                    let (sigma, k1) = (id.focal_sigma_px, id.k1);
                    *id = again;
                    id.focal_length_px = Some(cam.focal_length_px);
                    id.focal_sigma_px = sigma;
                    id.k1 = k1;
                }
            }
        }
        Ok(())
    }

    /// The attitude and residuals of `id`'s matches under `camera`.
    pub(crate) fn refit_matches(
        &self,
        centroids: &[[f64; 2]],
        camera: &Camera,
        id: &mut Identification,
    ) {
        let Some(r0) = id.r_icrs_to_cam else { return };
        let vectors = self.catalog.vectors();
        let obs: Vec<Vector3<f64>> = centroids
            .iter()
            .map(|c| camera.pixel_to_cam(c[0], c[1], id.mirrored))
            .collect();
        let (o, c): (Vec<Vector3<f64>>, Vec<Vector3<f64>>) = id
            .catalog_index
            .iter()
            .zip(&obs)
            .filter_map(|(s, v)| s.map(|s| (*v, vectors[s as usize])))
            .unzip();
        let Some(r) = wahba_from(&o, &c, &r0) else {
            return;
        };
        for ((res, s), v) in id.residuals_rad.iter_mut().zip(&id.catalog_index).zip(&obs) {
            if let Some(s) = s {
                // As verification gives them: the sine of the angle.
                *res = v.cross(&(r * vectors[*s as usize])).norm();
            }
        }
        id.r_icrs_to_cam = Some(r);
    }
}
