//! The nonlinear Whipple bicycle of the analysis: the benchmark bicycle's equations of motion
//! without linearization, for what the linear model cannot say — how a ride's weave differs
//! from the small motion's when the kick is large.
//!
//! In: a [`Benchmark`] parameter set and a state (lean, steer, their rates, the rear wheel's
//! rate). Out: the state's rates (integrated by [`NonlinearBicycle::simulate`]) and the lean and
//! steer angles against time.
//!
//! Formulation (independent of the simulator's, [`crate::sim`]): Maggi's equations (Kane's
//! method with the constraints solved for the dependent speeds) in the benchmark's own
//! coordinates (Meijaard, Papadopoulos, Ruina & Schwab 2007, §2: x forward, y right, z down,
//! the rear contact at the origin, every body's inertia given in the upright reference
//! configuration). Coordinates `q`: yaw ψ, roll φ, pitch θ of the rear frame
//! (`R_B = R_z(ψ) R_x(φ) R_y(θ)`, θ = 0 upright), steer δ about the steer axis, the rear
//! contact's x and y, the wheels' angles β_R and β_F. Constraints: each wheel's material point at
//! the contact has zero velocity (two rows for the rear wheel, three for the front, the third
//! the derivative of the front contact staying on the ground). Independent speeds
//! `u = (φ̇, δ̇, β̇_R)`; `q̇ = S(q) u`, `q̈ = S u̇ + q̈_p` with `A q̈_p = −Ȧ q̇`; then
//! `(Sᵀ M S) u̇ = Sᵀ (Q − c − M q̈_p)`, M the full coordinates' mass matrix, Q gravity's
//! generalized force and c the convective (velocity-product) terms. Every Jacobian and
//! convective term comes from [`Jet`]s evaluated along a coordinate or the motion.

use crate::jet::v3::{add, cross, dot, scale, sub, V3};
use crate::jet::{Jet, Scalar};
use crate::model::Benchmark;
use nalgebra::{Matrix3, SMatrix, SVector, Vector3};

/// A rotation as rows: `world = R · body`.
type Rot<S> = [[S; 3]; 3];

const NQ: usize = 8;
/// The coordinates' indices.
const YAW: usize = 0;
const ROLL: usize = 1;
const PITCH: usize = 2;
const STEER: usize = 3;
const REAR_SPIN: usize = 6;
const FRONT_SPIN: usize = 7;
/// The independent speeds' coordinates (lean, steer, rear wheel) and the dependent ones.
const INDEPENDENT: [usize; 3] = [ROLL, STEER, REAR_SPIN];
const DEPENDENT: [usize; 5] = [YAW, PITCH, 4, 5, FRONT_SPIN];

fn konst<S: Scalar>(a: [f64; 3]) -> V3<S> {
    a.map(S::c)
}
fn apply<S: Scalar>(r: &Rot<S>, v: V3<S>) -> V3<S> {
    [dot(r[0], v), dot(r[1], v), dot(r[2], v)]
}
fn compose<S: Scalar>(a: &Rot<S>, b: &Rot<S>) -> Rot<S> {
    let col = |j: usize| [b[0][j], b[1][j], b[2][j]];
    let mut out = [[S::c(0.0); 3]; 3];
    for (i, row) in out.iter_mut().enumerate() {
        for (j, x) in row.iter_mut().enumerate() {
            *x = dot(a[i], col(j));
        }
    }
    out
}
fn column<S: Scalar>(r: &Rot<S>, j: usize) -> V3<S> {
    [r[0][j], r[1][j], r[2][j]]
}
/// Rotation by `angle` about the coordinate axis `axis` (0 = x, 1 = y, 2 = z), right-handed.
fn about<S: Scalar>(axis: usize, angle: S) -> Rot<S> {
    let (s, c) = (angle.sin(), angle.cos());
    let (o, z) = (S::c(1.0), S::c(0.0));
    match axis {
        0 => [[o, z, z], [z, c, -s], [z, s, c]],
        1 => [[c, z, s], [z, o, z], [-s, z, c]],
        _ => [[c, -s, z], [s, c, z], [z, z, o]],
    }
}
/// Rotation by `angle` about the unit vector `e` (Rodrigues).
fn about_unit<S: Scalar>(e: [f64; 3], angle: S) -> Rot<S> {
    let (s, c) = (angle.sin(), angle.cos());
    let k = S::c(1.0) - c;
    let e = konst::<S>(e);
    let mut r = [[S::c(0.0); 3]; 3];
    for i in 0..3 {
        for j in 0..3 {
            r[i][j] = k * e[i] * e[j];
        }
        r[i][i] = r[i][i] + c;
    }
    r[0][1] = r[0][1] - s * e[2];
    r[0][2] = r[0][2] + s * e[1];
    r[1][0] = r[1][0] + s * e[2];
    r[1][2] = r[1][2] - s * e[0];
    r[2][0] = r[2][0] - s * e[1];
    r[2][1] = r[2][1] + s * e[0];
    r
}

/// The four bodies in the order rear wheel, rear frame, front frame, front wheel.
const BODIES: usize = 4;

/// Where the bodies are, and how fast they turn, at coordinates `q` moving at `qd`.
struct Kinematics<S> {
    /// Mass centres (world, m).
    centres: [V3<S>; BODIES],
    /// Angular velocities (world, rad/s), linear in `qd`.
    omegas: [V3<S>; BODIES],
    /// The rear frame's and the front frame's rotations.
    rear: Rot<S>,
    front: Rot<S>,
    /// Each wheel's material point at the contact, relative to its centre.
    rear_contact_arm: V3<S>,
    front_contact_arm: V3<S>,
}

impl Kinematics<Jet> {
    /// The values alone.
    fn values(&self) -> Kinematics<f64> {
        let v3 = |a: V3<Jet>| a.map(|x| x.v);
        let rot = |r: &Rot<Jet>| r.map(|row| row.map(|x| x.v));
        Kinematics {
            centres: self.centres.map(v3),
            omegas: self.omegas.map(v3),
            rear: rot(&self.rear),
            front: rot(&self.front),
            rear_contact_arm: v3(self.rear_contact_arm),
            front_contact_arm: v3(self.front_contact_arm),
        }
    }
}

/// The nonlinear Whipple bicycle of one parameter set.
#[derive(Debug, Clone)]
pub struct NonlinearBicycle {
    p: Benchmark,
    /// The steer axis, pointing down, in the reference configuration (unit).
    steer_axis: [f64; 3],
    /// A point of the steer axis (where it meets the ground) in the reference configuration.
    steer_point: [f64; 3],
    /// Inertia tensors in the reference configuration (kg·m²), per body.
    inertia_ref: [Matrix3<f64>; BODIES],
    masses: [f64; BODIES],
    /// Mass centres in the reference configuration (m).
    centres_ref: [[f64; 3]; BODIES],
}

/// The state: coordinates `q` (ψ, φ, θ, δ, x, y, β_R, β_F) and independent speeds
/// `u` (φ̇, δ̇, β̇_R).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct State {
    pub q: [f64; NQ],
    pub u: [f64; 3],
}

/// A motion: lean and steer against time.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Motion {
    pub t_s: Vec<f64>,
    pub roll_rad: Vec<f64>,
    pub steer_rad: Vec<f64>,
    /// The rear wheel's rolling speed (m/s), `−β̇_R r_R`: the model's speed v.
    pub speed_mps: Vec<f64>,
    /// The independent speeds at the last sample.
    pub end_rates: [f64; 3],
}

impl NonlinearBicycle {
    pub fn new(p: &Benchmark) -> NonlinearBicycle {
        let (sl, cl) = p.lambda.sin_cos();
        let tensor = |xx: f64, yy: f64, zz: f64, xz: f64| {
            Matrix3::new(xx, 0.0, xz, 0.0, yy, 0.0, xz, 0.0, zz)
        };
        NonlinearBicycle {
            p: *p,
            steer_axis: [sl, 0.0, cl],
            steer_point: [p.w + p.c, 0.0, 0.0],
            inertia_ref: [
                tensor(p.i_rxx, p.i_ryy, p.i_rxx, 0.0),
                tensor(p.i_bxx, p.i_byy, p.i_bzz, p.i_bxz),
                tensor(p.i_hxx, p.i_hyy, p.i_hzz, p.i_hxz),
                tensor(p.i_fxx, p.i_fyy, p.i_fxx, 0.0),
            ],
            masses: [p.m_r, p.m_b, p.m_h, p.m_f],
            centres_ref: [
                [0.0, 0.0, -p.r_r],
                [p.x_b, 0.0, p.z_b],
                [p.x_h, 0.0, p.z_h],
                [p.w, 0.0, -p.r_f],
            ],
        }
    }

    /// The bodies' positions and rates at `q` moving at `qd` (rates linear in `qd`).
    fn kinematics<S: Scalar>(&self, q: &[S; NQ], qd: &[S; NQ]) -> Kinematics<S> {
        let rr = S::c(self.p.r_r);
        let yaw = about(2, q[YAW]);
        let rolled = compose(&yaw, &about(0, q[ROLL]));
        let rear = compose(&rolled, &about(1, q[PITCH]));
        let steer = about_unit(self.steer_axis, q[STEER]);
        let front = compose(&rear, &steer);
        // The rear wheel: its centre above the contact in the wheel's plane.
        let z_rolled = column(&rolled, 2);
        let contact = [q[4], q[5], S::c(0.0)];
        let rear_centre = sub(contact, scale(z_rolled, rr));
        let c_ref = konst::<S>(self.centres_ref[0]);
        let in_rear = |p_ref: V3<S>| add(rear_centre, apply(&rear, sub(p_ref, c_ref)));
        let a_ref = konst::<S>(self.steer_point);
        let in_front = |p_ref: V3<S>| in_rear(add(a_ref, apply(&steer, sub(p_ref, a_ref))));
        let frame_centre = in_rear(konst(self.centres_ref[1]));
        let fork_centre = in_front(konst(self.centres_ref[2]));
        let front_centre = in_front(konst(self.centres_ref[3]));
        // The front wheel's lowest point: down within its plane.
        let axle = column(&front, 1);
        let down = [S::c(0.0), S::c(0.0), S::c(1.0)];
        let d = sub(down, scale(axle, dot(down, axle)));
        let front_arm = scale(d, S::c(self.p.r_f) / dot(d, d).sqrt());
        // Angular velocities.
        let x_yawed = column(&yaw, 0);
        let y_rolled = column(&rolled, 1);
        let w_rear_frame = add(
            add(scale(down, qd[YAW]), scale(x_yawed, qd[ROLL])),
            scale(y_rolled, qd[PITCH]),
        );
        let w_fork = add(
            w_rear_frame,
            scale(apply(&rear, konst(self.steer_axis)), qd[STEER]),
        );
        Kinematics {
            centres: [rear_centre, frame_centre, fork_centre, front_centre],
            omegas: [
                add(w_rear_frame, scale(y_rolled, qd[REAR_SPIN])),
                w_rear_frame,
                w_fork,
                add(w_fork, scale(axle, qd[FRONT_SPIN])),
            ],
            rear,
            front,
            rear_contact_arm: scale(z_rolled, rr),
            front_contact_arm: front_arm,
        }
    }

    /// The contact constraints' material velocities (rear x, y; front x, y, z) from the
    /// centres' velocities and the wheels' angular velocities.
    fn contact_velocities<S: Scalar>(v_rear: V3<S>, v_front: V3<S>, k: &Kinematics<S>) -> [S; 5] {
        let r = add(v_rear, cross(k.omegas[0], k.rear_contact_arm));
        let f = add(v_front, cross(k.omegas[3], k.front_contact_arm));
        [r[0], r[1], f[0], f[1], f[2]]
    }

    /// The front contact's height (m, z down: 0 on the ground) at lean, steer and pitch, and
    /// its derivative by the pitch.
    fn front_contact_height(&self, roll: f64, steer: f64, pitch: f64) -> (f64, f64) {
        let mut q = [Jet::c(0.0); NQ];
        q[ROLL] = Jet::c(roll);
        q[STEER] = Jet::c(steer);
        q[PITCH] = Jet::var(pitch, 1.0);
        let k = self.kinematics(&q, &[Jet::c(0.0); NQ]);
        let z = k.centres[3][2] + k.front_contact_arm[2];
        (z.v, z.d)
    }

    /// The pitch at which the front wheel touches the ground at `roll` and `steer`: Newton's
    /// method from `guess`. `None` if it does not converge to 1e-14 m in 30 steps.
    fn pitch_from(&self, roll: f64, steer: f64, guess: f64) -> Option<f64> {
        let mut pitch = guess;
        for _ in 0..30 {
            let (z, dz) = self.front_contact_height(roll, steer, pitch);
            if z.abs() < 1e-14 {
                return Some(pitch);
            }
            if dz.abs() <= 1e-12 || dz.is_nan() {
                return None;
            }
            pitch -= z / dz;
        }
        None
    }

    /// The pitch at which the front wheel touches the ground at `roll` and `steer` (rad);
    /// `None` where there is none near upright.
    pub fn pitch(&self, roll: f64, steer: f64) -> Option<f64> {
        self.pitch_from(roll, steer, 0.0)
    }

    /// The state rolling upright and straight at `speed_mps`, perturbed to lean `roll`, steer
    /// `steer` and their rates.
    pub fn state(&self, speed_mps: f64, roll: f64, steer: f64, rates: [f64; 2]) -> Option<State> {
        let mut q = [0.0; NQ];
        q[ROLL] = roll;
        q[STEER] = steer;
        q[PITCH] = self.pitch(roll, steer)?;
        Some(State {
            q,
            u: [rates[0], rates[1], -speed_mps / self.p.r_r],
        })
    }

    /// `u̇` and `q̇` at `state`; `None` where the constraints are singular.
    pub fn rates(&self, state: &State) -> Option<([f64; NQ], [f64; 3])> {
        let q = state.q;
        let zero = [0.0; NQ];
        // Jacobians, column by column: the centres' velocities, the angular velocities and
        // the constraints' rows for a unit rate of each coordinate.
        let mut jv = [[[0.0; NQ]; 3]; BODIES];
        let mut jw = [[[0.0; NQ]; 3]; BODIES];
        let mut a = SMatrix::<f64, 5, NQ>::zeros();
        // The positions depend on the four angles alone (on the contact's x and y as a
        // translation, not at all on the wheels' angles): jets along those four; the other
        // columns directly.
        for j in 0..NQ {
            let mut unit = zero;
            unit[j] = 1.0;
            let (v, k) = match j {
                YAW | ROLL | PITCH | STEER => {
                    let jets: [Jet; NQ] =
                        std::array::from_fn(|i| Jet::var(q[i], if i == j { 1.0 } else { 0.0 }));
                    let k = self.kinematics(&jets, &unit.map(Jet::c));
                    (k.centres.map(|c| c.map(|x| x.d)), k.values())
                }
                _ => {
                    let along = match j {
                        4 => [1.0, 0.0, 0.0],
                        5 => [0.0, 1.0, 0.0],
                        _ => [0.0; 3],
                    };
                    ([along; BODIES], self.kinematics(&q, &unit))
                }
            };
            for b in 0..BODIES {
                for r in 0..3 {
                    jv[b][r][j] = v[b][r];
                    jw[b][r][j] = k.omegas[b][r];
                }
            }
            let c = Self::contact_velocities(v[0], v[3], &k);
            for (r, x) in c.iter().enumerate() {
                a[(r, j)] = *x;
            }
        }
        // The dependent speeds from the independent ones.
        let ad = SMatrix::<f64, 5, 5>::from_fn(|r, c| a[(r, DEPENDENT[c])]);
        let ai = SMatrix::<f64, 5, 3>::from_fn(|r, c| a[(r, INDEPENDENT[c])]);
        let lu = ad.lu();
        let dep = lu.solve(&(-ai))?;
        let mut s = SMatrix::<f64, NQ, 3>::zeros();
        for (c, &i) in INDEPENDENT.iter().enumerate() {
            s[(i, c)] = 1.0;
        }
        for (r, &i) in DEPENDENT.iter().enumerate() {
            for c in 0..3 {
                s[(i, c)] = dep[(r, c)];
            }
        }
        let u = SVector::<f64, 3>::from(state.u);
        let qd_vec = s * u;
        let qd: [f64; NQ] = std::array::from_fn(|i| qd_vec[i]);
        // Along the motion: the convective accelerations (q̈ = 0).
        let jets: [Jet; NQ] = std::array::from_fn(|i| Jet::var(q[i], qd[i]));
        let k = self.kinematics(&jets, &qd.map(Jet::c));
        let conv_a: [[f64; 3]; BODIES] = k.centres.map(|c| c.map(|x| x.dd));
        let vel: [[f64; 3]; BODIES] = k.centres.map(|c| c.map(|x| x.d));
        let omega: [[f64; 3]; BODIES] = k.omegas.map(|w| w.map(|x| x.v));
        let conv_alpha: [[f64; 3]; BODIES] = k.omegas.map(|w| w.map(|x| x.d));
        // The constraints' convective part: d/dt of (v + ω × arm) at q̈ = 0.
        let arm_v = |arm: V3<Jet>| arm.map(|x| x.v);
        let arm_d = |arm: V3<Jet>| arm.map(|x| x.d);
        let constraint_conv = |b: usize, arm: V3<Jet>| {
            add(
                add(conv_a[b], cross(conv_alpha[b], arm_v(arm))),
                cross(omega[b], arm_d(arm)),
            )
        };
        let rb = constraint_conv(0, k.rear_contact_arm);
        let fb = constraint_conv(3, k.front_contact_arm);
        let b = SVector::<f64, 5>::from([rb[0], rb[1], fb[0], fb[1], fb[2]]);
        let _ = vel;
        let pd = lu.solve(&(-b))?;
        let mut qdd_p = SVector::<f64, NQ>::zeros();
        for (r, &i) in DEPENDENT.iter().enumerate() {
            qdd_p[i] = pd[r];
        }
        // Mass matrix, gravity and convective forces in the full coordinates.
        let rot = |r: &Rot<Jet>| Matrix3::from_fn(|i, j| r[i][j].v);
        let (rear, front) = (rot(&k.rear), rot(&k.front));
        let mut m = SMatrix::<f64, NQ, NQ>::zeros();
        let mut f = SVector::<f64, NQ>::zeros();
        for body in 0..BODIES {
            let r = if body < 2 { &rear } else { &front };
            let inertia = r * self.inertia_ref[body] * r.transpose();
            let jvb = SMatrix::<f64, 3, NQ>::from_fn(|i, j| jv[body][i][j]);
            let jwb = SMatrix::<f64, 3, NQ>::from_fn(|i, j| jw[body][i][j]);
            let mass = self.masses[body];
            m += mass * jvb.transpose() * jvb + jwb.transpose() * inertia * jwb;
            let w = Vector3::from(omega[body]);
            let gravity = Vector3::new(0.0, 0.0, mass * self.p.g);
            let linear = gravity - mass * Vector3::from(conv_a[body]);
            let angular = -(inertia * Vector3::from(conv_alpha[body]) + w.cross(&(inertia * w)));
            f += jvb.transpose() * linear + jwb.transpose() * angular;
        }
        let reduced_m = s.transpose() * m * s;
        let reduced_f = s.transpose() * (f - m * qdd_p);
        let ud = reduced_m.lu().solve(&reduced_f)?;
        Some((qd, [ud[0], ud[1], ud[2]]))
    }

    /// The motion from `start` over `duration_s`, sampled at `rate_hz` (classical Runge–Kutta at
    /// a tenth of the sample interval, the pitch put back on the constraint after every step);
    /// `None` if the equations become singular or the bicycle falls past 1.2 rad of lean.
    pub fn simulate(
        &self,
        start: State,
        duration_s: f64,
        rate_hz: f64,
        substeps: usize,
    ) -> Option<Motion> {
        let substeps = substeps.max(1);
        let dt = 1.0 / (rate_hz * substeps as f64);
        let samples = (duration_s * rate_hz).round() as usize + 1;
        let mut motion = Motion::default();
        let mut x = start;
        let deriv = |s: &State| self.rates(s);
        let step = |s: &State, k: &([f64; NQ], [f64; 3]), h: f64| State {
            q: std::array::from_fn(|i| s.q[i] + h * k.0[i]),
            u: std::array::from_fn(|i| s.u[i] + h * k.1[i]),
        };
        for n in 0..samples {
            motion.t_s.push(n as f64 / rate_hz);
            motion.roll_rad.push(x.q[ROLL]);
            motion.steer_rad.push(x.q[STEER]);
            motion.speed_mps.push(-x.u[2] * self.p.r_r);
            if n + 1 == samples {
                motion.end_rates = x.u;
                break;
            }
            for _ in 0..substeps {
                let k1 = deriv(&x)?;
                let k2 = deriv(&step(&x, &k1, 0.5 * dt))?;
                let k3 = deriv(&step(&x, &k2, 0.5 * dt))?;
                let k4 = deriv(&step(&x, &k3, dt))?;
                let mut next = State {
                    q: std::array::from_fn(|i| {
                        x.q[i] + dt / 6.0 * (k1.0[i] + 2.0 * k2.0[i] + 2.0 * k3.0[i] + k4.0[i])
                    }),
                    u: std::array::from_fn(|i| {
                        x.u[i] + dt / 6.0 * (k1.1[i] + 2.0 * k2.1[i] + 2.0 * k3.1[i] + k4.1[i])
                    }),
                };
                next.q[PITCH] = self.pitch_from(next.q[ROLL], next.q[STEER], next.q[PITCH])?;
                x = next;
            }
            if x.q[ROLL].abs() >= 1.2 || x.q[ROLL].is_nan() {
                return None;
            }
        }
        Some(motion)
    }

    /// The total mechanical energy (J): the bodies' kinetic energy and gravity's potential
    /// (zero with every mass centre on the ground). `None` where the constraints are singular.
    pub fn energy(&self, state: &State) -> Option<f64> {
        let (qd, _) = self.rates(state)?;
        let jets: [Jet; NQ] = std::array::from_fn(|i| Jet::var(state.q[i], qd[i]));
        let k = self.kinematics(&jets, &qd.map(Jet::c));
        let rot = |r: &Rot<Jet>| Matrix3::from_fn(|i, j| r[i][j].v);
        let (rear, front) = (rot(&k.rear), rot(&k.front));
        let mut energy = 0.0;
        for body in 0..BODIES {
            let r = if body < 2 { &rear } else { &front };
            let inertia = r * self.inertia_ref[body] * r.transpose();
            let v = Vector3::from(k.centres[body].map(|x| x.d));
            let w = Vector3::from(k.omegas[body].map(|x| x.v));
            let m = self.masses[body];
            energy += 0.5 * m * v.norm_squared() + 0.5 * w.dot(&(inertia * w))
                - m * self.p.g * k.centres[body][2].v;
        }
        Some(energy)
    }

    /// The state matrix of lean and steer (`[φ, δ, φ̇, δ̇]`) linearized at upright at
    /// `speed_mps`, by central differences of [`NonlinearBicycle::rates`] (step 1e-6).
    pub fn linearized(&self, speed_mps: f64) -> Option<nalgebra::Matrix4<f64>> {
        let h = 1e-6;
        let accel = |x: [f64; 4]| -> Option<[f64; 2]> {
            let s = self.state(speed_mps, x[0], x[1], [x[2], x[3]])?;
            let (_, ud) = self.rates(&s)?;
            Some([ud[0], ud[1]])
        };
        let mut a = nalgebra::Matrix4::zeros();
        a[(0, 2)] = 1.0;
        a[(1, 3)] = 1.0;
        for j in 0..4 {
            let mut plus = [0.0; 4];
            let mut minus = [0.0; 4];
            plus[j] = h;
            minus[j] = -h;
            let (p, m) = (accel(plus)?, accel(minus)?);
            a[(2, j)] = (p[0] - m[0]) / (2.0 * h);
            a[(3, j)] = (p[1] - m[1]) / (2.0 * h);
        }
        Some(a)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::Canonical;

    #[test]
    fn its_linearization_is_the_benchmarks() {
        let p = Benchmark::meijaard_2007();
        let bike = NonlinearBicycle::new(&p);
        let model = Canonical::from_benchmark(&p);
        for v in [0.5, 2.0, 4.3, 6.0, 9.0] {
            let a = bike.linearized(v).unwrap();
            let b = model.state_matrix(v).unwrap();
            let err = (a - b).abs().max();
            assert!(err < 1e-6, "v {v}: {a} against {b}");
        }
    }

    /// The equations conserve energy (no force but gravity does work on a bicycle rolling
    /// without slip): a motion of 0.05–0.1 rad, weaving and turning for 3 s, keeps its energy
    /// to 1e-9 of its kinetic energy (classical Runge–Kutta at 1 ms).
    #[test]
    fn a_large_motion_keeps_its_energy() {
        let p = Benchmark::meijaard_2007();
        let bike = NonlinearBicycle::new(&p);
        for v in [4.6, 6.5, 8.0] {
            let start = bike.state(v, 0.05, 0.1, [0.3, -0.5]).unwrap();
            let e0 = bike.energy(&start).unwrap();
            let kinetic = e0
                - bike
                    .energy(&bike.state(0.0, 0.05, 0.1, [0.0, 0.0]).unwrap())
                    .unwrap();
            let motion = bike.simulate(start, 3.0, 100.0, 10).unwrap();
            let n = motion.t_s.len() - 1;
            let end = State {
                q: {
                    // The yaw and the contact's place do not enter the energy.
                    let mut q = [0.0; NQ];
                    q[ROLL] = motion.roll_rad[n];
                    q[STEER] = motion.steer_rad[n];
                    q[PITCH] = bike.pitch(q[ROLL], q[STEER]).unwrap();
                    q
                },
                u: motion.end_rates,
            };
            let drift = (bike.energy(&end).unwrap() - e0).abs() / kinetic;
            assert!(
                drift < 1e-9,
                "v {v}: energy drift {drift:e} of the kinetic energy"
            );
            assert!(
                motion.roll_rad.iter().any(|r| (r - 0.05).abs() > 0.01),
                "it moved"
            );
        }
    }

    /// A motion a millionth of a radian in size is the linear model's: over 2 s at 5 m/s, lean
    /// and steer follow `ẋ = A x` (the benchmark's state matrix, integrated in 1 ms steps) to
    /// 1e-6 of their size.
    #[test]
    fn a_small_motion_is_the_linear_models() {
        let p = Benchmark::meijaard_2007();
        let bike = NonlinearBicycle::new(&p);
        let a = Canonical::from_benchmark(&p).state_matrix(5.0).unwrap();
        let x0 = nalgebra::Vector4::new(1e-6, -2e-6, 3e-6, 1e-6);
        let start = bike.state(5.0, x0[0], x0[1], [x0[2], x0[3]]).unwrap();
        let motion = bike.simulate(start, 2.0, 100.0, 10).unwrap();
        let mut x = x0;
        let h = 1e-3;
        for k in 0..motion.t_s.len() {
            let err = (motion.roll_rad[k] - x[0])
                .abs()
                .max((motion.steer_rad[k] - x[1]).abs());
            assert!(err < 1e-6 * 1e-6 + 1e-12, "t {}: {err:e}", motion.t_s[k]);
            for _ in 0..10 {
                let k1 = a * x;
                let k2 = a * (x + k1 * (0.5 * h));
                let k3 = a * (x + k2 * (0.5 * h));
                let k4 = a * (x + k3 * h);
                x += (k1 + k2 * 2.0 + k3 * 2.0 + k4) * (h / 6.0);
            }
        }
    }
}
