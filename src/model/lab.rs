//! The lab's parametrization (seed §3, §5.3.5, Parametros.m) converted to the benchmark form.
//!
//! The lab's bicycle (`data/lab_bike.toml`, see [`crate::inertia::bike`]): points in the upright
//! bicycle, x forward and z up from the rear hub G₂; the frame (solid 3) and handlebar (solid 4)
//! have their own axes, rotated by β about y (Parametros.m `A23 = [[cos β, −sin β], [sin β,
//! cos β]]` maps upright coordinates to local ones); the steer axis is the handlebar's local z
//! axis through its centre of gravity G₄ (the lab's model puts G₄ on the steer axis).
//!
//! Conversion (benchmark: origin at the rear contact, x forward, z down):
//! 1. Rear contact at (0, −R_t): a point (x, z) becomes (x, −(z + R_t)).
//! 2. Front hub G₅ = G₄ + (Δx, Δz); wheelbase w = x of G₅ (its contact is below it).
//! 3. Steer axis direction in upright coordinates: the local z axis, (sin β, cos β); its tilt from
//!    the vertical λ = atan2(−sin β, cos β) (β = 5.968 rad = −18.05° gives λ = 0.3150 rad).
//! 4. Trail: the axis through G₄ meets the ground (z = z₅ − R_d) at x_g; c = x_g − w.
//! 5. Inertias: `I_up = R I_local Rᵀ` with R the rotation local → upright (about y by −β's
//!    inverse, `A23ᵀ`), then z up → z down flips the sign of I_xz (`D I D`, D = diag(1, −1, −1)).
//! 6. Wheels: I_xx = I_zz about a diameter, I_yy the spin inertia (eq. 83).

use super::params::{Benchmark, ParamError};
use crate::inertia::bike::{Body, LabBike};
use std::path::Path;

/// Rotates a local xz-symmetric tensor into upright z-up coordinates and then into the
/// benchmark's z-down axes (steps 5 of the module's list). Returns (I_xx, I_yy, I_zz, I_xz).
fn tensor_to_benchmark(b: &Body, beta: f64) -> (f64, f64, f64, f64) {
    let (s, c) = beta.sin_cos();
    // Columns of R: the local x axis (cos β, −sin β) and z axis (sin β, cos β) in upright coordinates.
    let (rxx, rxz, rzx, rzz) = (c, s, -s, c);
    let (ixx, izz, ixz) = (b.ixx_kgm2, b.izz_kgm2, b.ixz_kgm2);
    // I_up = R I Rᵀ in the xz plane.
    let a_xx = rxx * (rxx * ixx + rxz * ixz) + rxz * (rxx * ixz + rxz * izz);
    let a_xz = rxx * (rzx * ixx + rzz * ixz) + rxz * (rzx * ixz + rzz * izz);
    let a_zz = rzx * (rzx * ixx + rzz * ixz) + rzz * (rzx * ixz + rzz * izz);
    (a_xx, b.iyy_kgm2, a_zz, -a_xz)
}

/// The lab's bicycle in the benchmark form (module doc, steps 1–6). Standard errors are not
/// set here: see [`crate::model::uncertain::Parametrized::from_lab`].
pub fn lab_to_benchmark(bike: &LabBike) -> Benchmark {
    let g = &bike.geometry;
    let (rt, rd) = (g.rear_wheel_radius_m, g.front_wheel_radius_m);
    let beta = g.frame_axes_beta_rad;
    let (sb, cb) = beta.sin_cos();
    let down = |p: [f64; 2]| (p[0], -(p[1] + rt));
    let (x_b, z_b) = down(g.frame_cg_from_rear_hub_m);
    let g4 = g.handlebar_cg_from_rear_hub_m;
    let (x_h, z_h) = down(g4);
    let g5 = [
        g4[0] + g.front_hub_from_handlebar_cg_m[0],
        g4[1] + g.front_hub_from_handlebar_cg_m[1],
    ];
    let w = g5[0];
    let lambda = (-sb).atan2(cb);
    let ground_z = g5[1] - rd;
    let t = (ground_z - g4[1]) / cb;
    let c = g4[0] + t * sb - w;
    let (bxx, byy, bzz, bxz) = tensor_to_benchmark(&bike.frame, beta);
    let (hxx, hyy, hzz, hxz) = tensor_to_benchmark(&bike.handlebar, beta);
    Benchmark {
        w,
        c,
        lambda,
        g: bike.gravity_mps2,
        r_r: rt,
        m_r: bike.rear_wheel.mass_kg,
        i_rxx: bike.rear_wheel.ixx_kgm2,
        i_ryy: bike.rear_wheel.iyy_kgm2,
        x_b,
        z_b,
        m_b: bike.frame.mass_kg,
        i_bxx: bxx,
        i_byy: byy,
        i_bzz: bzz,
        i_bxz: bxz,
        x_h,
        z_h,
        m_h: bike.handlebar.mass_kg,
        i_hxx: hxx,
        i_hyy: hyy,
        i_hzz: hzz,
        i_hxz: hxz,
        r_f: rd,
        m_f: bike.front_wheel.mass_kg,
        i_fxx: bike.front_wheel.ixx_kgm2,
        i_fyy: bike.front_wheel.iyy_kgm2,
        se: [0.0; 26],
    }
}

/// The lab's geometry defines the steer axis through the handlebar's centre of gravity; a file
/// that says otherwise cannot be converted.
pub fn check_geometry(bike: &LabBike, path: &Path) -> Result<(), ParamError> {
    if bike.geometry.handlebar_cg_on_steer_axis {
        Ok(())
    } else {
        Err(ParamError::Invalid {
            path: path.to_path_buf(),
            message: "geometry.handlebar_cg_on_steer_axis = false: the lab's parametrization defines the steer axis through the handlebar's centre of gravity (seed §3); set it to true".into(),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_seed_bicycle_has_eq_92s_local_coordinates() {
        // Parametros.m: x3 = 0.4198, z3 = 0.0296 in the frame's axes; undo the rotation.
        let bike = LabBike::seed();
        let b = lab_to_benchmark(&bike);
        let beta = bike.geometry.frame_axes_beta_rad;
        let (s, c) = beta.sin_cos();
        let (x, z) = (b.x_b, -b.z_b - 0.3);
        assert!((c * x - s * z - 0.4198).abs() < 1e-4 && (s * x + c * z - 0.0296).abs() < 1e-4);
        assert!((b.lambda - 0.315015).abs() < 1e-5, "{}", b.lambda);
        assert!((b.w - 1.023414).abs() < 1e-6);
    }
}
