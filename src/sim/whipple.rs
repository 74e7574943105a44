//! The nonlinear Whipple bicycle, for the ride simulator: four rigid bodies, knife-edge wheels
//! rolling without slip on flat ground, no linearization anywhere.
//!
//! Coordinates (Moore 2012, "Human control of a bicycle", ch. 4): q₁, q₂ the rear contact point
//! in the ground plane, q₃ yaw, q₄ roll, q₅ pitch of the rear frame (about its y axis, so that its
//! z axis is the steer axis: q₅ = λ upright), q₆ the rear wheel's angle, q₇ steer, q₈ the front
//! wheel's angle; ground axes n₁ forward, n₂ right, n₃ down. The frames: A = R_z(q₃),
//! B = A R_x(q₄), C = B R_y(q₅) (rear frame), D = C R_y(q₆) (rear wheel), E = C R_z(q₇) (fork and
//! handlebar), F = E R_y(q₈) (front wheel).
//!
//! Equations (projected Newton–Euler, with the contact constraints by Lagrange multipliers):
//! `Σ_b J_vᵀ m (a − g n₃) + J_ωᵀ (I α + ω × I ω) = Aᵀ λ`, `A q̈ = −Ȧ q̇`, where the velocity
//! Jacobians `J_v`, `J_ω`, the constraint matrix A (the contact points' material velocities:
//! 2 rows for the rear wheel, 3 for the front, one of them the holonomic front-contact constraint
//! differentiated) and every convective term come exactly from [`Jet`]s.
//!
//! This is the simulator's own physics: it shares no equations with the analysis model
//! ([`crate::model`]); the tests compare the two.

pub use crate::jet::v3::V3;
use crate::jet::v3::{add, scale, sub};
use crate::jet::{Jet, Scalar};
use crate::model::Benchmark;
use nalgebra::{SMatrix, SVector};

/// A rotation as its three columns: the body's axes in ground coordinates.
pub type Frame<S> = [V3<S>; 3];

/// `parent · R_axis(angle)`: the frame turned about its own axis `axis` (0 = x, 1 = y, 2 = z).
fn turn<S: Scalar>(parent: &Frame<S>, axis: usize, angle: S) -> Frame<S> {
    let (s, c) = (angle.sin(), angle.cos());
    let (i, j) = match axis {
        0 => (1, 2),
        1 => (2, 0),
        _ => (0, 1),
    };
    let mut out = *parent;
    out[i] = add(scale(parent[i], c), scale(parent[j], s));
    out[j] = sub(scale(parent[j], c), scale(parent[i], s));
    out
}

/// The geometry and mass distribution in Moore's parametrization.
#[derive(Debug, Clone, Copy)]
pub struct WhippleParams {
    pub rr: f64,
    pub rf: f64,
    /// Rear wheel centre to the steer axis, perpendicular to it (m).
    pub d1: f64,
    /// Along the steer axis between the rear and front offset lines (m).
    pub d2: f64,
    /// Front wheel centre to the steer axis (m).
    pub d3: f64,
    /// Rear frame centre of mass from the rear wheel centre, along c₁ and c₃ (m).
    pub l1: f64,
    pub l2: f64,
    /// Front frame centre of mass from the front wheel centre, along e₁ and e₃ (m).
    pub l3: f64,
    pub l4: f64,
    pub mc: f64,
    pub md: f64,
    pub me: f64,
    pub mf: f64,
    /// Rear frame inertia about its centre of mass, in frame C (kg·m²).
    pub ic: [[f64; 3]; 3],
    /// Rear wheel: about a diameter and about the axle.
    pub id11: f64,
    pub id22: f64,
    /// Front frame inertia about its centre of mass, in frame E.
    pub ie: [[f64; 3]; 3],
    pub if11: f64,
    pub if22: f64,
    pub g: f64,
    /// Steer axis tilt (rad): the rear frame's pitch when upright.
    pub lambda: f64,
}

impl WhippleParams {
    /// From the benchmark form (Meijaard et al. 2007): the steer axis tilt λ turns the
    /// benchmark's axes into the rear frame's (c₁ = (cos λ, 0, −sin λ), c₃ = (sin λ, 0, cos λ)).
    pub fn from_benchmark(b: &Benchmark) -> WhippleParams {
        let (sl, cl) = b.lambda.sin_cos();
        let d1 = (b.w + b.c) * cl - b.r_r * sl;
        let d3 = -b.c * cl + b.r_f * sl;
        let d2 = b.w * sl + (b.r_r - b.r_f) * cl;
        let l1 = b.x_b * cl - (b.z_b + b.r_r) * sl;
        let l2 = b.x_b * sl + (b.z_b + b.r_r) * cl;
        let l3 = (b.x_h - b.w) * cl - (b.z_h + b.r_f) * sl;
        let l4 = (b.x_h - b.w) * sl + (b.z_h + b.r_f) * cl;
        // I_C = Rᵀ I_N R with R's columns c₁, c₂, c₃.
        let rotate = |ixx: f64, iyy: f64, izz: f64, ixz: f64| {
            let c1 = [cl, 0.0, -sl];
            let c3 = [sl, 0.0, cl];
            let i = [[ixx, 0.0, ixz], [0.0, iyy, 0.0], [ixz, 0.0, izz]];
            let q = |a: [f64; 3], b: [f64; 3]| {
                (0..3)
                    .map(|r| (0..3).map(|s| a[r] * i[r][s] * b[s]).sum::<f64>())
                    .sum::<f64>()
            };
            [
                [q(c1, c1), 0.0, q(c1, c3)],
                [0.0, iyy, 0.0],
                [q(c3, c1), 0.0, q(c3, c3)],
            ]
        };
        WhippleParams {
            rr: b.r_r,
            rf: b.r_f,
            d1,
            d2,
            d3,
            l1,
            l2,
            l3,
            l4,
            mc: b.m_b,
            md: b.m_r,
            me: b.m_h,
            mf: b.m_f,
            ic: rotate(b.i_bxx, b.i_byy, b.i_bzz, b.i_bxz),
            id11: b.i_rxx,
            id22: b.i_ryy,
            ie: rotate(b.i_hxx, b.i_hyy, b.i_hzz, b.i_hxz),
            if11: b.i_fxx,
            if22: b.i_fyy,
            g: b.g,
            lambda: b.lambda,
        }
    }
}

/// Positions and orientations of everything, for one configuration.
struct Kinematics<S> {
    /// Rear wheel centre, rear frame CM, front frame CM, front wheel centre.
    do_: V3<S>,
    co: V3<S>,
    eo: V3<S>,
    fo: V3<S>,
    /// Rear and front contact points.
    dn: V3<S>,
    fn_: V3<S>,
    /// The steer axis' point at the rear offset line (anchor of the steer rotation).
    ce: V3<S>,
    a: Frame<S>,
    b: Frame<S>,
    c: Frame<S>,
    d: Frame<S>,
    e: Frame<S>,
    f: Frame<S>,
}

fn kinematics<S: Scalar>(p: &WhippleParams, q: &[S; 8]) -> Kinematics<S> {
    let n: Frame<S> = [
        [S::c(1.0), S::c(0.0), S::c(0.0)],
        [S::c(0.0), S::c(1.0), S::c(0.0)],
        [S::c(0.0), S::c(0.0), S::c(1.0)],
    ];
    let a = turn(&n, 2, q[2]);
    let b = turn(&a, 0, q[3]);
    let c = turn(&b, 1, q[4]);
    let d = turn(&c, 1, q[5]);
    let e = turn(&c, 2, q[6]);
    let f = turn(&e, 1, q[7]);
    let k = S::c;
    let dn = [q[0], q[1], k(0.0)];
    let do_ = sub(dn, scale(b[2], k(p.rr)));
    let co = add(do_, add(scale(c[0], k(p.l1)), scale(c[2], k(p.l2))));
    let ce = add(do_, scale(c[0], k(p.d1)));
    let fo = add(ce, add(scale(c[2], k(p.d2)), scale(e[0], k(p.d3))));
    let eo = add(fo, add(scale(e[0], k(p.l3)), scale(e[2], k(p.l4))));
    // The front contact: from the wheel's centre, the radius along n₃ projected on the wheel's plane.
    let e2 = e[1];
    let down = sub(n[2], scale(e2, e2[2]));
    let norm = (k(1.0) - e2[2] * e2[2]).sqrt();
    let fn_ = add(fo, scale(down, k(p.rf) / norm));
    Kinematics {
        do_,
        co,
        eo,
        fo,
        dn,
        fn_,
        ce,
        a,
        b,
        c,
        d,
        e,
        f,
    }
}

/// Value and rate parts of a jet vector.
fn val(v: V3<Jet>) -> [f64; 3] {
    [v[0].v, v[1].v, v[2].v]
}
fn rate(v: V3<Jet>) -> [f64; 3] {
    [v[0].d, v[1].d, v[2].d]
}
fn conv(v: V3<Jet>) -> [f64; 3] {
    [v[0].dd, v[1].dd, v[2].dd]
}

type M3 = SMatrix<f64, 3, 3>;
type C3 = SVector<f64, 3>;

fn frame_parts(fr: &Frame<Jet>) -> (M3, M3, M3) {
    let r = M3::from_fn(|i, j| fr[j][i].v);
    let rd = M3::from_fn(|i, j| fr[j][i].d);
    let rdd = M3::from_fn(|i, j| fr[j][i].dd);
    (r, rd, rdd)
}

/// `vee` of the skew part of a matrix: ω from `Ṙ Rᵀ`.
fn vee(m: &M3) -> C3 {
    C3::new(
        0.5 * (m[(2, 1)] - m[(1, 2)]),
        0.5 * (m[(0, 2)] - m[(2, 0)]),
        0.5 * (m[(1, 0)] - m[(0, 1)]),
    )
}

/// Velocities (per unit rate of one coordinate, or along `q̇`) of every body and contact.
struct Rates {
    /// Per body (C, D, E, F): centre-of-mass velocity and angular velocity.
    v: [C3; 4],
    w: [C3; 4],
    /// Per body: convective acceleration and angular acceleration (at q̈ = 0).
    a: [C3; 4],
    alpha: [C3; 4],
    /// Material velocity of the rear (2 horizontal components) and front (3) contact points,
    /// and their convective accelerations.
    contact: [f64; 5],
    contact_conv: [f64; 5],
    /// Per wheel (rear, front): the contact point's material velocity and convective
    /// acceleration (ground axes), the lever arm from the wheel's centre, and the wheel's axle
    /// with its rate (for the tyre model's rolling and lateral directions).
    cv: [C3; 2],
    ca: [C3; 2],
    rho: [C3; 2],
    axle: [C3; 2],
    axle_d: [C3; 2],
    /// Orientation of each body (for its inertia).
    r: [M3; 4],
}

fn rates(p: &WhippleParams, q: &[f64; 8], qd: &[f64; 8]) -> Rates {
    let jq: [Jet; 8] = std::array::from_fn(|i| Jet::var(q[i], qd[i]));
    let k = kinematics(p, &jq);
    let c3 = |x: [f64; 3]| C3::new(x[0], x[1], x[2]);
    let frames = [&k.c, &k.d, &k.e, &k.f];
    let points = [k.co, k.do_, k.eo, k.fo];
    let mut out = Rates {
        v: [C3::zeros(); 4],
        w: [C3::zeros(); 4],
        a: [C3::zeros(); 4],
        alpha: [C3::zeros(); 4],
        contact: [0.0; 5],
        contact_conv: [0.0; 5],
        cv: [C3::zeros(); 2],
        ca: [C3::zeros(); 2],
        rho: [C3::zeros(); 2],
        axle: [C3::zeros(); 2],
        axle_d: [C3::zeros(); 2],
        r: [M3::zeros(); 4],
    };
    for b in 0..4 {
        let (r, rd, rdd) = frame_parts(frames[b]);
        out.r[b] = r;
        out.w[b] = vee(&(rd * r.transpose()));
        out.alpha[b] = vee(&(rdd * r.transpose()));
        out.v[b] = c3(rate(points[b]));
        out.a[b] = c3(conv(points[b]));
    }
    // Contact points: v = v_centre + ω × ρ, ρ from the wheel's centre to the contact.
    for (n, (wheel, centre, contact, rows, axle)) in [
        (1usize, k.do_, k.dn, 0..2usize, k.d[1]),
        (3, k.fo, k.fn_, 2..5, k.f[1]),
    ]
    .into_iter()
    .enumerate()
    {
        let rho = sub(contact, centre);
        let (rho_v, rho_d) = (c3(val(rho)), c3(rate(rho)));
        let vel = c3(rate(centre)) + out.w[wheel].cross(&rho_v);
        let acc = c3(conv(centre)) + out.alpha[wheel].cross(&rho_v) + out.w[wheel].cross(&rho_d);
        for (slot, axis) in rows.zip(0..3) {
            out.contact[slot] = vel[axis];
            out.contact_conv[slot] = acc[axis];
        }
        out.cv[n] = vel;
        out.ca[n] = acc;
        out.rho[n] = rho_v;
        out.axle[n] = c3(val(axle));
        out.axle_d[n] = c3(rate(axle));
    }
    out
}

/// The generalized accelerations `q̈` at `(q, q̇)`, with the multipliers' `λ` (the contact
/// forces' generalized components), by the saddle-point system of the module's equations.
/// `q̇` must satisfy the velocity constraints. `None` when the system is singular.
pub fn accelerations(p: &WhippleParams, q: &[f64; 8], qd: &[f64; 8]) -> Option<[f64; 8]> {
    accelerations_with(p, q, qd, &columns(p, q), &[], Motion::Free)
}

/// How the rear wheel moves.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Motion {
    /// Coasting: the speed is free (it changes with the loads and the motion).
    #[default]
    Free,
    /// The rear wheel's rate held constant (the seed's eq. 33), by whatever torque that takes.
    ImposedSpeed,
}

/// As [`accelerations`], with applied loads and the rear wheel's motion.
pub fn accelerations_loaded(
    p: &WhippleParams,
    q: &[f64; 8],
    qd: &[f64; 8],
    loads: &[Load],
    motion: Motion,
) -> Option<[f64; 8]> {
    accelerations_with(p, q, qd, &columns(p, q), loads, motion)
}

/// The frame's and the fork's orientation and centre of mass along jets (for sensors):
/// `(C, r_C, E, r_E)`.
pub fn kinematics_jets(
    p: &WhippleParams,
    q: &[Jet; 8],
) -> (Frame<Jet>, V3<Jet>, Frame<Jet>, V3<Jet>) {
    let k = kinematics(p, q);
    (k.c, k.co, k.e, k.eo)
}

/// The bodies, in the order used by [`Load`].
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Body {
    Frame,
    RearWheel,
    Fork,
    FrontWheel,
}

impl Body {
    fn index(self) -> usize {
        match self {
            Body::Frame => 0,
            Body::RearWheel => 1,
            Body::Fork => 2,
            Body::FrontWheel => 3,
        }
    }
}

/// An applied load beyond gravity and the contacts.
#[derive(Debug, Clone, Copy)]
pub enum Load {
    /// A force (N, ground axes) at a point given in the body's own axes relative to its centre
    /// of mass (wheels: their centres).
    Force {
        body: Body,
        offset_body_m: [f64; 3],
        force_n: [f64; 3],
    },
    /// A torque (N·m, ground axes) on a body.
    Torque { body: Body, torque_nm: [f64; 3] },
    /// A torque between frame and fork about the steer axis (N·m), positive turning the fork
    /// towards positive steer.
    Steer(f64),
}

/// The generalized forces of `loads` (virtual power: `Qᵢ = Jᵢ · F`).
fn generalized_forces(cols: &[Rates], along: &Rates, loads: &[Load]) -> [f64; 8] {
    let mut out = [0.0; 8];
    for load in loads {
        for (i, c) in cols.iter().enumerate() {
            out[i] += match *load {
                Load::Force {
                    body,
                    offset_body_m,
                    force_n,
                } => {
                    let b = body.index();
                    let rho = along.r[b] * C3::from(offset_body_m);
                    (c.v[b] + c.w[b].cross(&rho)).dot(&C3::from(force_n))
                }
                Load::Torque { body, torque_nm } => c.w[body.index()].dot(&C3::from(torque_nm)),
                Load::Steer(t) => {
                    if i == 6 {
                        t
                    } else {
                        0.0
                    }
                }
            };
        }
    }
    out
}

/// The velocity of a point of a body (ground axes), from the rates along `q̇`.
pub fn point_velocity(
    p: &WhippleParams,
    q: &[f64; 8],
    qd: &[f64; 8],
    body: Body,
    offset_body_m: [f64; 3],
) -> [f64; 3] {
    let r = rates(p, q, qd);
    let b = body.index();
    let v = r.v[b] + r.w[b].cross(&(r.r[b] * C3::from(offset_body_m)));
    [v[0], v[1], v[2]]
}

/// The velocity Jacobian's columns: the rates of everything per unit rate of each coordinate,
/// from one evaluation of the kinematics. q₁, q₂ translate the whole bicycle over the ground;
/// every other coordinate is a rotation about a joint axis `a` through an anchor `o` (yaw about
/// n₃ and roll about a₁ through the rear contact, pitch about b₂ and the rear wheel about c₂
/// through the rear wheel's centre, steer about c₃ through the steer axis, the front wheel
/// about e₂ through its centre), turning the bodies downstream of it: their angular velocity
/// is `a` and a point's velocity is `a × (point − o)`.
fn columns(p: &WhippleParams, q: &[f64; 8]) -> Vec<Rates> {
    let k = kinematics(p, q);
    let c3 = |x: [f64; 3]| C3::new(x[0], x[1], x[2]);
    let points = [c3(k.co), c3(k.do_), c3(k.eo), c3(k.fo)];
    let contacts = [c3(k.dn), c3(k.fn_)];
    let axles = [c3(k.d[1]), c3(k.f[1])];
    // (axis, anchor, which bodies turn: frame, rear wheel, fork, front wheel)
    let joints: [(C3, C3, [bool; 4]); 6] = [
        (C3::z(), c3(k.dn), [true; 4]),
        (c3(k.a[0]), c3(k.dn), [true; 4]),
        (c3(k.b[1]), c3(k.do_), [true; 4]),
        (c3(k.c[1]), c3(k.do_), [false, true, false, false]),
        (c3(k.c[2]), c3(k.ce), [false, false, true, true]),
        (c3(k.e[1]), c3(k.fo), [false, false, false, true]),
    ];
    let z = C3::zeros();
    let blank = || Rates {
        v: [z; 4],
        w: [z; 4],
        a: [z; 4],
        alpha: [z; 4],
        contact: [0.0; 5],
        contact_conv: [0.0; 5],
        cv: [z; 2],
        ca: [z; 2],
        rho: [z; 2],
        axle: axles,
        axle_d: [z; 2],
        r: [M3::zeros(); 4],
    };
    let mut out = Vec::with_capacity(8);
    for u in [C3::x(), C3::y()] {
        let mut r = blank();
        r.v = [u; 4];
        r.cv = [u; 2];
        r.contact = [u[0], u[1], u[0], u[1], u[2]];
        out.push(r);
    }
    for (axis, anchor, turns) in joints {
        let mut r = blank();
        for b in 0..4 {
            if turns[b] {
                r.w[b] = axis;
                r.v[b] = axis.cross(&(points[b] - anchor));
            }
        }
        // Contact points: the wheel's material point there, v = v_centre + ω × ρ.
        for (n, wheel) in [(0usize, 1usize), (1, 3)] {
            let rho = contacts[n] - points[wheel];
            r.rho[n] = rho;
            r.cv[n] = r.v[wheel] + r.w[wheel].cross(&rho);
        }
        r.contact = [r.cv[0][0], r.cv[0][1], r.cv[1][0], r.cv[1][1], r.cv[1][2]];
        out.push(r);
    }
    out
}

fn accelerations_with(
    p: &WhippleParams,
    q: &[f64; 8],
    qd: &[f64; 8],
    cols: &[Rates],
    loads: &[Load],
    motion: Motion,
) -> Option<[f64; 8]> {
    let along = rates(p, q, qd);
    let rows: Vec<([f64; 8], f64)> = (0..5)
        .map(|r| {
            (
                std::array::from_fn(|i| cols[i].contact[r]),
                along.contact_conv[r],
            )
        })
        .collect();
    solve_dynamics(p, cols, &along, loads, motion, &rows)
}

/// The saddle-point system: the equations of motion with the applied loads, and the velocity
/// constraints `rows` (each `(aᵢ, convective)` with `a · q̈ + convective = 0`), at most five.
fn solve_dynamics(
    p: &WhippleParams,
    cols: &[Rates],
    along: &Rates,
    loads: &[Load],
    motion: Motion,
    rows: &[([f64; 8], f64)],
) -> Option<[f64; 8]> {
    let applied = generalized_forces(cols, along, loads);
    let masses = [p.mc, p.md, p.me, p.mf];
    let inertia_body = [
        M3::from_fn(|i, j| p.ic[i][j]),
        M3::from_diagonal(&C3::new(p.id11, p.id22, p.id11)),
        M3::from_fn(|i, j| p.ie[i][j]),
        M3::from_diagonal(&C3::new(p.if11, p.if22, p.if11)),
    ];
    let mut sys = SMatrix::<f64, 14, 14>::zeros();
    let mut rhs = SVector::<f64, 14>::zeros();
    let gravity = C3::new(0.0, 0.0, p.g);
    for b in 0..4 {
        let inn = along.r[b] * inertia_body[b] * along.r[b].transpose();
        let force = (gravity - along.a[b]) * masses[b];
        let torque = -(inn * along.alpha[b] + along.w[b].cross(&(inn * along.w[b])));
        for i in 0..8 {
            rhs[i] += cols[i].v[b].dot(&force) + cols[i].w[b].dot(&torque);
            for j in 0..8 {
                sys[(i, j)] += masses[b] * cols[i].v[b].dot(&cols[j].v[b])
                    + cols[i].w[b].dot(&(inn * cols[j].w[b]));
            }
        }
    }
    for (i, a) in applied.iter().enumerate() {
        rhs[i] += a;
    }
    for r in 0..5 {
        match rows.get(r) {
            Some((a, conv)) => {
                for i in 0..8 {
                    sys[(8 + r, i)] = a[i];
                    sys[(i, 8 + r)] = -a[i];
                }
                rhs[8 + r] = -conv;
            }
            None => sys[(8 + r, 8 + r)] = 1.0,
        }
    }
    match motion {
        // q̈₆ = 0: its multiplier is the driving torque that holds the wheel's rate.
        Motion::ImposedSpeed => {
            sys[(13, 5)] = 1.0;
            sys[(5, 13)] = -1.0;
        }
        Motion::Free => sys[(13, 13)] = 1.0,
    }
    let x = sys.lu().solve(&rhs)?;
    Some(std::array::from_fn(|i| x[i]))
}

// ---------------------------------------------------------------------------------------------
// Lateral tyre compliance.

/// Lateral tyre compliance in place of the lateral no-slip constraints: each wheel still rolls
/// without longitudinal slip and stays on the ground, but slides sideways against a lateral
/// force `F` that relaxes towards the steady-state force over a relaxation length σ:
/// `(σ/v) Ḟ + F = N (−C_α α + C_γ γ)`, α the side-slip angle of the contact, γ the wheel's camber,
/// N its static normal load. (Pacejka, Tire and Vehicle Dynamics, ch. 1 and 7; typical values
/// C_α ≈ 11 /rad, C_γ ≈ 0.6 /rad, σ ≈ 0.18 m.)
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TyreModel {
    /// Cornering stiffness per unit normal load (1/rad).
    pub cornering_per_rad: f64,
    /// Camber stiffness per unit normal load (1/rad).
    pub camber_per_rad: f64,
    pub relaxation_length_m: f64,
}

/// A wheel's rolling direction in the ground plane (the wheel plane's intersection with the
/// ground, forward) and its rate: `t = (a × n₃)/|a × n₃|` for the axle a.
fn rolling_direction(along: &Rates, wheel: usize) -> (C3, C3) {
    let z = C3::z();
    let u = along.axle[wheel].cross(&z);
    let ud = along.axle_d[wheel].cross(&z);
    let nu = u.norm();
    let t = u / nu;
    (t, (ud - t * t.dot(&ud)) / nu)
}

/// The constraints with compliant tyres: each wheel's contact does not slip along its rolling
/// direction, and the front contact stays on the ground (the rear one does by construction).
fn tyre_rows(cols: &[Rates], along: &Rates) -> Vec<([f64; 8], f64)> {
    let (tr, trd) = rolling_direction(along, 0);
    let (tf, tfd) = rolling_direction(along, 1);
    [(0usize, tr, trd), (1, tf, tfd), (1, C3::z(), C3::zeros())]
        .into_iter()
        .map(|(w, dir, dir_d)| {
            (
                std::array::from_fn(|i| cols[i].cv[w].dot(&dir)),
                along.ca[w].dot(&dir) + dir_d.dot(&along.cv[w]),
            )
        })
        .collect()
}

/// A tyre model with the wheels' static normal loads (rear, front; N).
#[derive(Debug, Clone, Copy)]
pub struct Tyres {
    pub model: TyreModel,
    pub normal_n: [f64; 2],
}

/// A stretch of simulated time: its start, its length, the sample step (s).
#[derive(Debug, Clone, Copy)]
pub struct Span {
    pub t0_s: f64,
    pub duration_s: f64,
    pub dt_s: f64,
}

/// The state with compliant tyres: the coordinates, the independent rates (q̇₁, q̇₂, q̇₃, q̇₄,
/// q̇₇: the contact point sliding over the ground, yaw, roll, steer) and the two lateral
/// forces (N). Pitch and the wheels' spins follow from the remaining constraints.
pub type TyreState = [f64; 15];

const TYRE_INDEPENDENT: [usize; 5] = [0, 1, 2, 3, 6];
const TYRE_DEPENDENT: [usize; 3] = [4, 5, 7];

/// All eight rates of a tyre state: the dependent ones solve the constraints of [`tyre_rows`]
/// (their directions need only the axles, which every column carries).
fn tyre_rates_with(cols: &[Rates], y: &TyreState) -> Option<[f64; 8]> {
    let dir = |a: C3| {
        let u = a.cross(&C3::z());
        u / u.norm()
    };
    let dirs = [
        (0usize, dir(cols[2].axle[0])),
        (1, dir(cols[2].axle[1])),
        (1, C3::z()),
    ];
    let a = SMatrix::<f64, 3, 8>::from_fn(|r, c| cols[c].cv[dirs[r].0].dot(&dirs[r].1));
    let mut qd = [0.0; 8];
    for (k, &i) in TYRE_INDEPENDENT.iter().enumerate() {
        qd[i] = y[8 + k];
    }
    let a_dep = SMatrix::<f64, 3, 3>::from_fn(|r, c| a[(r, TYRE_DEPENDENT[c])]);
    let rhs = SVector::<f64, 3>::from_fn(|r, _| {
        -TYRE_INDEPENDENT
            .iter()
            .map(|&i| a[(r, i)] * qd[i])
            .sum::<f64>()
    });
    let x = a_dep.lu().solve(&rhs)?;
    for (k, &i) in TYRE_DEPENDENT.iter().enumerate() {
        qd[i] = x[k];
    }
    Some(qd)
}

/// A tyre state from coordinates and rates that satisfy the constraints, with no lateral force.
pub fn tyre_state(q: &[f64; 8], qd: &[f64; 8]) -> TyreState {
    let mut y = [0.0; 15];
    y[..8].copy_from_slice(q);
    for (k, &i) in TYRE_INDEPENDENT.iter().enumerate() {
        y[8 + k] = qd[i];
    }
    y
}

/// The tyre forces as loads and the forces' rates, for `(q, q̇, F)`.
fn tyre_forces(
    along: &Rates,
    tyre: &TyreModel,
    normal_n: [f64; 2],
    force_n: [f64; 2],
) -> (Vec<Load>, [f64; 2]) {
    let mut loads = Vec::new();
    let mut rates_out = [0.0; 2];
    for (n, body) in [(0usize, Body::RearWheel), (1, Body::FrontWheel)] {
        let (t, _) = rolling_direction(along, n);
        let lateral = C3::z().cross(&t);
        let centre_v = along.v[body.index()];
        let v_long = centre_v.dot(&t).abs().max(1e-3);
        let slip = along.cv[n].dot(&lateral).atan2(v_long);
        let camber = along.axle[n].dot(&C3::z()).clamp(-1.0, 1.0).asin();
        let steady = normal_n[n] * (-tyre.cornering_per_rad * slip + tyre.camber_per_rad * camber);
        rates_out[n] = v_long / tyre.relaxation_length_m * (steady - force_n[n]);
        let r = along.r[body.index()];
        let offset = r.transpose() * along.rho[n];
        let f = lateral * force_n[n];
        loads.push(Load::Force {
            body,
            offset_body_m: [offset[0], offset[1], offset[2]],
            force_n: [f[0], f[1], f[2]],
        });
    }
    (loads, rates_out)
}

/// The motion at a tyre state: all eight rates `q̇`, accelerations `q̈`, and the lateral
/// forces' rates.
pub fn tyre_motion(
    p: &WhippleParams,
    tyres: &Tyres,
    t: f64,
    y: &TyreState,
    drive: Drive<'_>,
) -> Option<([f64; 8], [f64; 8], [f64; 2])> {
    let q: [f64; 8] = std::array::from_fn(|i| y[i]);
    let cols = columns(p, &q);
    let qd = tyre_rates_with(&cols, y)?;
    let along = rates(p, &q, &qd);
    let (mut loads, f_rates) = tyre_forces(&along, &tyres.model, tyres.normal_n, [y[13], y[14]]);
    loads.extend((drive.loads)(&LoadInput {
        t,
        q: &q,
        qd: &qd,
        velocities: velocities_of(&along),
        actuator_torque_nm: None,
    }));
    let qdd = solve_dynamics(
        p,
        &cols,
        &along,
        &loads,
        drive.motion,
        &tyre_rows(&cols, &along),
    )?;
    Some((qd, qdd, f_rates))
}

/// The derivative of a [`TyreState`] at time `t`.
pub fn tyre_derivative(
    p: &WhippleParams,
    tyres: &Tyres,
    t: f64,
    y: &TyreState,
    drive: Drive<'_>,
) -> Option<TyreState> {
    let (qd, qdd, f_rates) = tyre_motion(p, tyres, t, y, drive)?;
    let mut out = [0.0; 15];
    out[..8].copy_from_slice(&qd);
    for (k, &i) in TYRE_INDEPENDENT.iter().enumerate() {
        out[8 + k] = qdd[i];
    }
    out[13] = f_rates[0];
    out[14] = f_rates[1];
    Some(out)
}

/// A coast on compliant tyres from `(q, q̇)` with zero lateral forces, sampled every `dt_s`.
/// After every step the pitch is put back on the ground; the rates satisfy the remaining
/// constraints by construction.
pub fn coast_on_tyres(
    p: &WhippleParams,
    tyres: &Tyres,
    q0: &[f64; 8],
    qd0: &[f64; 8],
    span: Span,
    tol: &super::ode::Tolerance,
    drive: Drive<'_>,
) -> Result<Vec<TyreState>, super::ode::OdeError> {
    let rhs = |t: f64, y: &TyreState| tyre_derivative(p, tyres, t, y, drive);
    let project = |y: &mut TyreState| {
        let q: [f64; 8] = std::array::from_fn(|i| y[i]);
        if let Some(q5) = pitch_on_ground(p, &q, q[4]) {
            y[4] = q5;
        }
    };
    let mut state = tyre_state(q0, qd0);
    let Span {
        t0_s,
        duration_s,
        dt_s,
    } = span;
    let n = (duration_s / dt_s).round() as usize;
    let mut out = Vec::with_capacity(n + 1);
    let mut h = dt_s / 4.0;
    let mut fsal = None;
    out.push(state);
    for k in 0..n {
        super::ode::integrate(
            &rhs,
            &project,
            t0_s + k as f64 * dt_s,
            t0_s + (k + 1) as f64 * dt_s,
            &mut state,
            &mut h,
            &mut fsal,
            tol,
        )?;
        out.push(state);
    }
    Ok(out)
}

/// The front contact's height above the ground (zero when the configuration is possible).
pub fn front_contact_height(p: &WhippleParams, q: &[f64; 8]) -> f64 {
    -kinematics(p, q).fn_[2]
}

/// The pitch q₅ that puts the front wheel on the ground, by Newton's method from `guess`.
pub fn pitch_on_ground(p: &WhippleParams, q: &[f64; 8], guess: f64) -> Option<f64> {
    let mut q5 = guess;
    for _ in 0..50 {
        let jq: [Jet; 8] = std::array::from_fn(|i| {
            if i == 4 {
                Jet::var(q5, 1.0)
            } else {
                Jet::c(q[i])
            }
        });
        let z = kinematics(p, &jq).fn_[2];
        if z.d == 0.0 {
            return None;
        }
        let step = z.v / z.d;
        q5 -= step;
        if step.abs() < 1e-15 {
            return Some(q5);
        }
    }
    None
}

/// The dependent rates `(q̇₁, q̇₂, q̇₃, q̇₅, q̇₈)` for given roll, rear wheel and steer rates
/// `(q̇₄, q̇₆, q̇₇)`: the full `q̇` satisfying the contact constraints.
pub fn constrained_rates(
    p: &WhippleParams,
    q: &[f64; 8],
    roll_rate: f64,
    rear_wheel_rate: f64,
    steer_rate: f64,
) -> Option<[f64; 8]> {
    constrained_rates_with(&columns(p, q), roll_rate, rear_wheel_rate, steer_rate)
}

fn constrained_rates_with(
    columns: &[Rates],
    roll_rate: f64,
    rear_wheel_rate: f64,
    steer_rate: f64,
) -> Option<[f64; 8]> {
    let cols: Vec<[f64; 5]> = columns.iter().map(|r| r.contact).collect();
    let dep = [0usize, 1, 2, 4, 7];
    let a = SMatrix::<f64, 5, 5>::from_fn(|r, c| cols[dep[c]][r]);
    let b = SVector::<f64, 5>::from_fn(|r, _| {
        -(cols[3][r] * roll_rate + cols[5][r] * rear_wheel_rate + cols[6][r] * steer_rate)
    });
    let x = a.lu().solve(&b)?;
    let mut qd = [0.0; 8];
    qd[3] = roll_rate;
    qd[5] = rear_wheel_rate;
    qd[6] = steer_rate;
    for (k, &i) in dep.iter().enumerate() {
        qd[i] = x[k];
    }
    Some(qd)
}

/// Kinetic plus potential energy (J), the potential from the ground (n₃ down).
pub fn energy(p: &WhippleParams, q: &[f64; 8], qd: &[f64; 8]) -> f64 {
    let r = rates(p, q, qd);
    let k = kinematics(p, q);
    let masses = [p.mc, p.md, p.me, p.mf];
    let heights = [k.co[2], k.do_[2], k.eo[2], k.fo[2]];
    let inertia_body = [
        M3::from_fn(|i, j| p.ic[i][j]),
        M3::from_diagonal(&C3::new(p.id11, p.id22, p.id11)),
        M3::from_fn(|i, j| p.ie[i][j]),
        M3::from_diagonal(&C3::new(p.if11, p.if22, p.if11)),
    ];
    (0..4)
        .map(|b| {
            let inn = r.r[b] * inertia_body[b] * r.r[b].transpose();
            0.5 * masses[b] * r.v[b].norm_squared() + 0.5 * r.w[b].dot(&(inn * r.w[b]))
                - masses[b] * p.g * heights[b]
        })
        .sum()
}

/// The upright straight run at forward speed `v` (m/s) perturbed to roll, steer and their rates:
/// the full state `(q, q̇)` (pitch on the ground, dependent rates from the constraints).
pub fn upright_state(
    p: &WhippleParams,
    v: f64,
    roll: f64,
    steer: f64,
    roll_rate: f64,
    steer_rate: f64,
) -> Option<([f64; 8], [f64; 8])> {
    let mut q = [0.0; 8];
    q[3] = roll;
    q[6] = steer;
    q[4] = pitch_on_ground(p, &q, p.lambda)?;
    let qd = constrained_rates(p, &q, roll_rate, -v / p.rr, steer_rate)?;
    Some((q, qd))
}

/// The state integrated: the eight coordinates and the independent rates (roll, rear wheel,
/// steer); the other rates follow from the contact constraints.
pub type RideState = [f64; 11];

/// A ride state from coordinates and rates that satisfy the contact constraints.
pub fn ride_state(q: &[f64; 8], qd: &[f64; 8]) -> RideState {
    let mut y = [0.0; 11];
    y[..8].copy_from_slice(q);
    y[8] = qd[3];
    y[9] = qd[5];
    y[10] = qd[6];
    y
}

/// The full rates `q̇` of a ride state.
pub fn full_rates(p: &WhippleParams, y: &RideState) -> Option<[f64; 8]> {
    let q: [f64; 8] = std::array::from_fn(|i| y[i]);
    constrained_rates(p, &q, y[8], y[9], y[10])
}

/// A free coast of the Whipple bicycle (no driving torque, speed free to change) from `y` for
/// `duration_s`, sampled every `dt_s`: the states at each sample, the first being `y`. After
/// every step the pitch is put back on the ground (the holonomic constraint), so its drift stays
/// at the Newton tolerance.
pub fn coast(
    p: &WhippleParams,
    y: RideState,
    duration_s: f64,
    dt_s: f64,
    tol: &super::ode::Tolerance,
) -> Result<Vec<RideState>, super::ode::OdeError> {
    coast_loaded(
        p,
        y,
        0.0,
        duration_s,
        dt_s,
        tol,
        Drive {
            loads: &|_| Vec::new(),
            motion: Motion::Free,
            actuator: None,
        },
    )
}

/// Loads as a function of time, coordinates and rates.
pub type Loads<'a> = dyn Fn(&LoadInput<'_>) -> Vec<Load> + 'a;

/// What a load may depend on: time, coordinates, rates, and the bodies' velocities.
pub struct LoadInput<'a> {
    pub t: f64,
    pub q: &'a [f64; 8],
    pub qd: &'a [f64; 8],
    /// Centre-of-mass velocities (ground axes, m/s) of the frame, rear wheel, fork, front wheel.
    pub velocities: [[f64; 3]; 4],
    /// The steer actuator's torque (N·m) where it is a state of its own ([`Actuator`]): the
    /// loads apply it in place of the command. `None` without a lagged actuator.
    pub actuator_torque_nm: Option<f64>,
}

fn velocities_of(along: &Rates) -> [[f64; 3]; 4] {
    std::array::from_fn(|b| [along.v[b][0], along.v[b][1], along.v[b][2]])
}

/// The bodies' centre-of-mass velocities at `(q, q̇)` (frame, rear wheel, fork, front wheel).
pub fn body_velocities(p: &WhippleParams, q: &[f64; 8], qd: &[f64; 8]) -> [[f64; 3]; 4] {
    velocities_of(&rates(p, q, qd))
}

/// What drives a coast beyond gravity: applied loads, the rear wheel's motion and a steer
/// actuator whose torque lags its command.
#[derive(Clone, Copy)]
pub struct Drive<'a> {
    pub loads: &'a Loads<'a>,
    pub motion: Motion,
    pub actuator: Option<Actuator<'a>>,
}

/// A steer actuator whose torque τ follows its command u through a first-order lag,
/// `T τ̇ = u − τ` (a motor driver's current loop, the firmware's filter on its command): τ is
/// integrated with the bicycle ([`coast_actuated`]) and handed to the loads as
/// [`LoadInput::actuator_torque_nm`].
#[derive(Clone, Copy)]
pub struct Actuator<'a> {
    /// The lag's time constant T (s, positive).
    pub lag_s: f64,
    /// The command u (N·m) at a state, as the loads would apply it without the lag.
    pub command: &'a dyn Fn(&LoadInput<'_>) -> f64,
}

/// As [`coast`], from time `t0_s`, driven by `drive` (its actuator's torque, if any, left out
/// of the states: [`coast_actuated`] keeps it).
pub fn coast_loaded(
    p: &WhippleParams,
    y: RideState,
    t0_s: f64,
    duration_s: f64,
    dt_s: f64,
    tol: &super::ode::Tolerance,
    drive: Drive<'_>,
) -> Result<Vec<RideState>, super::ode::OdeError> {
    let span = Span {
        t0_s,
        duration_s,
        dt_s,
    };
    let states = coast_actuated(p, y, span, tol, drive)?;
    Ok(states.into_iter().map(|(y, _)| y).collect())
}

/// As [`coast_loaded`], each sample with the actuator's torque (N·m; 0 without an actuator).
/// The actuator's torque is a twelfth state, started at its command (the lag's steady state);
/// without an actuator its rate is zero, so the error control (a maximum over the states) and
/// every other state are those of the bicycle alone.
pub fn coast_actuated(
    p: &WhippleParams,
    y: RideState,
    span: Span,
    tol: &super::ode::Tolerance,
    drive: Drive<'_>,
) -> Result<Vec<(RideState, f64)>, super::ode::OdeError> {
    let Span {
        t0_s,
        duration_s,
        dt_s,
    } = span;
    let input_at = |y: &[f64; 12]| -> Option<([f64; 8], Vec<Rates>, [f64; 8])> {
        let q: [f64; 8] = std::array::from_fn(|i| y[i]);
        let cols = columns(p, &q);
        let qd = constrained_rates_with(&cols, y[8], y[9], y[10])?;
        Some((q, cols, qd))
    };
    let rhs = |t: f64, y: &[f64; 12]| -> Option<[f64; 12]> {
        let (q, cols, qd) = input_at(y)?;
        let along = rates(p, &q, &qd);
        let input = LoadInput {
            t,
            q: &q,
            qd: &qd,
            velocities: velocities_of(&along),
            actuator_torque_nm: drive.actuator.map(|_| y[11]),
        };
        let loads = (drive.loads)(&input);
        let rows: Vec<([f64; 8], f64)> = (0..5)
            .map(|r| {
                (
                    std::array::from_fn(|i| cols[i].contact[r]),
                    along.contact_conv[r],
                )
            })
            .collect();
        let qdd = solve_dynamics(p, &cols, &along, &loads, drive.motion, &rows)?;
        let mut out = [0.0; 12];
        out[..8].copy_from_slice(&qd);
        out[8] = qdd[3];
        out[9] = qdd[5];
        out[10] = qdd[6];
        if let Some(a) = drive.actuator {
            out[11] = ((a.command)(&input) - y[11]) / a.lag_s;
        }
        Some(out)
    };
    let project = |y: &mut [f64; 12]| {
        let q: [f64; 8] = std::array::from_fn(|i| y[i]);
        if let Some(q5) = pitch_on_ground(p, &q, q[4]) {
            y[4] = q5;
        }
    };
    let mut state = [0.0; 12];
    state[..11].copy_from_slice(&y);
    if let Some(a) = drive.actuator {
        let (q, _, qd) = input_at(&state).ok_or(super::ode::OdeError::Rhs(t0_s))?;
        let along = rates(p, &q, &qd);
        state[11] = (a.command)(&LoadInput {
            t: t0_s,
            q: &q,
            qd: &qd,
            velocities: velocities_of(&along),
            actuator_torque_nm: None,
        });
    }
    let split = |s: &[f64; 12]| -> (RideState, f64) { (std::array::from_fn(|i| s[i]), s[11]) };
    let n = (duration_s / dt_s).round() as usize;
    let mut out = Vec::with_capacity(n + 1);
    let mut h = dt_s / 4.0;
    let mut fsal = None;
    out.push(split(&state));
    for k in 0..n {
        let (a, b) = (t0_s + k as f64 * dt_s, t0_s + (k + 1) as f64 * dt_s);
        super::ode::integrate(&rhs, &project, a, b, &mut state, &mut h, &mut fsal, tol)?;
        out.push(split(&state));
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn kicked(p: &WhippleParams, v: f64, roll_rate: f64) -> RideState {
        let (q, qd) = upright_state(p, v, 0.0, 0.0, roll_rate, 0.0).unwrap();
        ride_state(&q, &qd)
    }

    /// The benchmark bicycle for the simulator, its linear model, and the weave eigenvalue at `v`.
    fn benchmark_weave(
        v: f64,
    ) -> (
        WhippleParams,
        crate::model::Canonical,
        nalgebra::Complex<f64>,
    ) {
        let b = Benchmark::meijaard_2007();
        let linear = crate::model::Canonical::from_benchmark(&b);
        let weave = linear
            .eigenvalues(v)
            .unwrap()
            .into_iter()
            .find(|z| z.im > 0.0)
            .unwrap();
        (WhippleParams::from_benchmark(&b), linear, weave)
    }

    /// A damped sinusoid fitted to `z(t)` has the weave's σ and ω within 0.5 %.
    fn assert_decays_with(t: &[f64], z: &[f64], weave: nalgebra::Complex<f64>) {
        let fit = crate::fit::fit_from_frequency(t, z, weave.im, false).unwrap();
        let (sigma, omega) = (-fit.sigma().value, fit.omega_d().value);
        assert!(
            (sigma / weave.re - 1.0).abs() < 0.005,
            "σ {sigma} vs {}",
            weave.re
        );
        assert!(
            (omega / weave.im - 1.0).abs() < 0.005,
            "ω {omega} vs {}",
            weave.im
        );
    }

    #[test]
    fn coasting_conserves_energy_and_keeps_the_wheels_on_the_ground() {
        let p = WhippleParams::from_benchmark(&Benchmark::meijaard_2007());
        let y0 = kicked(&p, 5.0, 0.5);
        let traj = coast(
            &p,
            y0,
            10.0,
            0.01,
            &super::super::ode::Tolerance {
                rtol: 1e-12,
                atol: 1e-13,
                max_steps: 1_000_000,
            },
        )
        .unwrap();
        let e = |y: &RideState| {
            energy(
                &p,
                &std::array::from_fn(|i| y[i]),
                &full_rates(&p, y).unwrap(),
            )
        };
        let e0 = e(&y0);
        let worst = traj
            .iter()
            .map(|y| ((e(y) - e0) / e0).abs())
            .fold(0.0, f64::max);
        assert!(worst < 1e-8, "energy drifts by {worst:e} relative");
        let drift = traj
            .iter()
            .map(|y| front_contact_height(&p, &std::array::from_fn(|i| y[i])).abs())
            .fold(0.0, f64::max);
        assert!(drift < 1e-10, "front contact off the ground by {drift:e} m");
        // It moved: the kick set it weaving, and it travelled ~50 m.
        let last = traj.last().unwrap();
        assert!((last[0].powi(2) + last[1].powi(2)).sqrt() > 40.0);
    }

    /// Linearizing the nonlinear equations at the upright straight run reproduces the benchmark's
    /// linear state matrix (Meijaard et al. 2007) to 1e-7 (central differences, step 1e-6).
    #[test]
    fn jacobian_at_upright_is_the_benchmark_state_matrix() {
        let b = Benchmark::meijaard_2007();
        let p = WhippleParams::from_benchmark(&b);
        let linear = crate::model::Canonical::from_benchmark(&b);
        for v in [1.0, 4.6, 8.0] {
            let f = |x: [f64; 4]| -> [f64; 4] {
                let (q, qd) = upright_state(&p, v, x[0], x[1], x[2], x[3]).unwrap();
                let qdd = accelerations(&p, &q, &qd).unwrap();
                [x[2], x[3], qdd[3], qdd[6]]
            };
            let a = linear.state_matrix(v).unwrap();
            let h = 1e-6;
            for j in 0..4 {
                let mut xp = [0.0; 4];
                let mut xm = [0.0; 4];
                xp[j] = h;
                xm[j] = -h;
                let (fp, fm) = (f(xp), f(xm));
                for i in 0..4 {
                    let d = (fp[i] - fm[i]) / (2.0 * h);
                    assert!(
                        (d - a[(i, j)]).abs() < 1e-7 * a[(i, j)].abs().max(1.0),
                        "v = {v}, A[{i}][{j}]: {d} vs {}",
                        a[(i, j)]
                    );
                }
            }
        }
    }

    /// Basu-Mandal, Chatterjee & Papadopoulos 2007, Table 1: their coordinates (x, y, z) of the
    /// rear wheel centre (z up), θ yaw, ψ = π/2 − lean, φ = π + λ − pitch, ψ_f = −steer, β_r, β_f.
    /// Mapped to these coordinates with the rear contact point below the wheel centre:
    /// q₁ = −r sin θ cos ψ − x, q₂ = y − r cos θ cos ψ, q₃ = −θ, q₄ = π/2 − ψ, q₅ = π + λ − φ,
    /// q₆ = −β_r, q₇ = −ψ_f, q₈ = −β_f (their x axis points backwards, z up).
    #[test]
    fn reproduces_basu_mandal_2007_table_1() {
        let b = Benchmark::meijaard_2007();
        let p = WhippleParams::from_benchmark(&b);
        let (rr, lam) = (b.r_r, b.lambda);
        let basu_q = [
            0.0,
            0.0,
            0.2440472102925,
            0.0,
            0.9501292851472,
            3.1257073014894,
            0.2311385135743,
            0.0,
            0.0,
        ];
        let basu_qd = [
            -2.8069345714545,
            -0.1480982396001,
            0.1058778746261,
            0.7830033527065,
            0.6068425835418,
            -0.0119185528069,
            0.4859824687093,
            8.9129896614890,
            8.0133620584155,
        ];
        let want = [
            -0.5041626315047,
            -0.3449706619454,
            -1.4604528332980,
            0.8353281706379,
            -7.8555281128244,
            0.1205543897884,
            -4.6198904039403,
            1.8472554144217,
            2.4548072904550,
        ];
        // Theirs → ours, with rates through jets.
        let j: [Jet; 9] = std::array::from_fn(|i| Jet::var(basu_q[i], basu_qd[i]));
        let (x, y, th, psi, phi, psif, br, bf) = (j[0], j[1], j[3], j[4], j[5], j[6], j[7], j[8]);
        let c = Jet::c;
        let half_pi = c(std::f64::consts::FRAC_PI_2);
        let ours = [
            -(c(rr) * th.sin() * psi.cos()) - x,
            y - c(rr) * th.cos() * psi.cos(),
            -th,
            half_pi - psi,
            c(std::f64::consts::PI + lam) - phi,
            -br,
            -psif,
            -bf,
        ];
        let q: [f64; 8] = std::array::from_fn(|i| ours[i].v);
        let qd: [f64; 8] = std::array::from_fn(|i| ours[i].d);
        assert!(front_contact_height(&p, &q).abs() < 1e-12);
        let qdd = accelerations(&p, &q, &qd).unwrap();
        // Ours → theirs: coordinates as functions of ours, jets carrying q̇ and q̈.
        let m: [Jet; 8] = std::array::from_fn(|i| Jet {
            v: q[i],
            d: qd[i],
            dd: qdd[i],
        });
        let (s3, c3, s4, c4) = (m[2].sin(), m[2].cos(), m[3].sin(), m[3].cos());
        let theirs = [
            c(rr) * s3 * s4 - m[0],
            c(rr) * c3 * s4 + m[1],
            c(rr) * c4,
            -m[2],
            half_pi - m[3],
            c(std::f64::consts::PI + lam) - m[4],
            -m[6],
            -m[5],
            -m[7],
        ];
        for k in 0..9 {
            let got = theirs[k].dd;
            assert!(
                (got - want[k]).abs() <= 1e-10 * want[k].abs(),
                "coordinate {k}: {got:.13} vs {:.13}",
                want[k]
            );
        }
    }

    /// A small disturbance shaped like the weave (the linear model's eigenvector at 5 m/s, 1e-4 rad
    /// of roll) decays in the nonlinear coast with the linear weave eigenvalue: a damped sinusoid
    /// fitted to the roll gives σ and ω within 0.5 %. (A kick at the saddle also excites capsize
    /// and castor; the eigenvector isolates the weave, which is what this compares.)
    #[test]
    fn a_small_weave_decays_with_the_linear_eigenvalue() {
        let v = 5.0;
        let (p, linear, weave) = benchmark_weave(v);
        let m = linear.mode_shape(v, weave).unwrap();
        let k = 1e-4 / m[0].norm();
        let x0: [f64; 4] = std::array::from_fn(|i| (m[i] * k).re);
        let (q, qd) = upright_state(&p, v, x0[0], x0[1], x0[2], x0[3]).unwrap();
        let traj = coast(
            &p,
            ride_state(&q, &qd),
            6.0,
            0.01,
            &super::super::ode::Tolerance::default(),
        )
        .unwrap();
        let t: Vec<f64> = (0..traj.len()).map(|i| i as f64 * 0.01).collect();
        let roll: Vec<f64> = traj.iter().map(|s| s[3]).collect();
        assert_decays_with(&t, &roll, weave);
    }

    #[test]
    fn stiff_tyres_approach_rolling_without_slip() {
        let b = Benchmark::meijaard_2007();
        let p = WhippleParams::from_benchmark(&b);
        let y0 = kicked(&p, 5.0, 0.3);
        let no_slip = coast(&p, y0, 3.0, 0.01, &super::super::ode::Tolerance::default()).unwrap();
        let q0: [f64; 8] = std::array::from_fn(|i| y0[i]);
        let qd0 = full_rates(&p, &y0).unwrap();
        let m = b.m_r + b.m_b + b.m_h + b.m_f;
        let nf = b.g * (b.x_b * b.m_b + b.x_h * b.m_h + b.w * b.m_f) / b.w;
        let normal = [b.g * m - nf, nf];
        let stiff = TyreModel {
            cornering_per_rad: 300.0,
            camber_per_rad: 0.0,
            relaxation_length_m: 0.005,
        };
        let none: &Loads<'_> = &|_| Vec::new();
        let run = |model: TyreModel| {
            let tyres = Tyres {
                model,
                normal_n: normal,
            };
            let span = Span {
                t0_s: 0.0,
                duration_s: 3.0,
                dt_s: 0.01,
            };
            coast_on_tyres(
                &p,
                &tyres,
                &q0,
                &qd0,
                span,
                &super::super::ode::Tolerance::default(),
                Drive {
                    loads: none,
                    motion: Motion::Free,
                    actuator: None,
                },
            )
            .unwrap()
        };
        let tyres = run(stiff);
        let peak = no_slip.iter().map(|y| y[3].abs()).fold(0.0, f64::max);
        let worst = no_slip
            .iter()
            .zip(&tyres)
            .map(|(a, b)| (a[3] - b[3]).abs())
            .fold(0.0, f64::max);
        assert!(worst < 0.02 * peak, "roll differs by {worst} (peak {peak})");
        // And typical tyres are softer: the weave differs measurably.
        let soft = run(TyreModel {
            cornering_per_rad: 11.0,
            camber_per_rad: 0.6,
            relaxation_length_m: 0.18,
        });
        let diff = no_slip
            .iter()
            .zip(&soft)
            .map(|(a, b)| (a[3] - b[3]).abs())
            .fold(0.0, f64::max);
        assert!(
            diff > 0.02 * peak,
            "typical tyres change the roll by only {diff}"
        );
    }

    /// A small kick at the saddle (a 5 N, 50 ms lateral pulse) at 5 m/s: projected on the
    /// linear weave's left eigenvector (which separates it from capsize and castor), the
    /// nonlinear coast decays with the weave eigenvalue within 0.5 %.
    #[test]
    fn a_small_kick_decays_with_the_linear_weave_eigenvalue() {
        use nalgebra::{Complex, Matrix4};
        let v = 5.0;
        let (p, linear, weave) = benchmark_weave(v);
        // Left eigenvector: the right one of Aᵀ, by inverse iteration.
        let at = linear
            .state_matrix(v)
            .unwrap()
            .transpose()
            .map(|x| Complex::new(x, 0.0));
        let lu =
            (at - Matrix4::<Complex<f64>>::identity() * (weave + Complex::new(1e-9, 1e-9))).lu();
        let mut w = nalgebra::Vector4::from_element(Complex::new(1.0, 0.0));
        for _ in 0..4 {
            w = lu.solve(&w).unwrap();
            w /= Complex::new(w.norm(), 0.0);
        }
        let y0 = kicked(&p, v, 0.0);
        let loads = |input: &LoadInput<'_>| -> Vec<Load> {
            if input.t < 0.05 {
                let f = 5.0 * (std::f64::consts::PI * input.t / 0.05).sin();
                vec![Load::Force {
                    body: Body::Frame,
                    offset_body_m: [0.0, 0.0, -0.3],
                    force_n: [0.0, f, 0.0],
                }]
            } else {
                vec![]
            }
        };
        let tol = super::super::ode::Tolerance::default();
        let traj = coast_loaded(
            &p,
            y0,
            0.0,
            6.0,
            0.01,
            &tol,
            Drive {
                loads: &loads,
                motion: Motion::Free,
                actuator: None,
            },
        )
        .unwrap();
        let (mut t, mut z) = (Vec::new(), Vec::new());
        for (i, y) in traj.iter().enumerate().skip(30) {
            let qd = full_rates(&p, y).unwrap();
            let x = [y[3], y[6], qd[3], qd[6]];
            let modal: Complex<f64> = (0..4).map(|k| w[k].conj() * x[k]).sum();
            t.push(i as f64 * 0.01);
            z.push(modal.re);
        }
        assert_decays_with(&t, &z, weave);
    }
}
