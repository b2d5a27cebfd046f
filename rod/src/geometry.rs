//! Discrete rod geometry (Bergou et al. 2008, *Discrete Elastic Rods*, §4).
//!
//! A discrete rod is a polyline `x₀ … x_n` with edges `eⁱ = x_{i+1} − x_i`. At an interior
//! vertex the turning angle φ between consecutive edges and the discrete curvature binormal
//! `(κb) = 2 e⁰ × e¹ / (|e⁰||e¹| + e⁰·e¹)` (magnitude `2 tan(φ/2)`) measure bending.
//! Each edge carries an orthonormal reference frame `(t, d₁, d₂)` that is moved by parallel
//! transport, and a material frame `(t, m₁, m₂)` rotated from it by the twist angle θ.
//! All lengths in metres, angles in radians.

use nalgebra::{Matrix3, Vector3};

/// 3-vector of f64 (positions in m, directions unitless).
pub type V3 = Vector3<f64>;
/// 3 × 3 matrix of f64.
pub type M3 = Matrix3<f64>;

/// Edge vector `x₁ − x₀` (m).
pub fn edge(x0: &V3, x1: &V3) -> V3 {
    x1 - x0
}

/// Unit tangent of an edge, `None` for a zero-length edge.
pub fn tangent(e: &V3) -> Option<V3> {
    let l = e.norm();
    (l > 0.0).then(|| e / l)
}

/// Turning angle φ ∈ [0, π] between consecutive edges `e0` and `e1` (rad), computed with
/// `atan2(|e0 × e1|, e0 · e1)`, which is accurate for tiny and for near-π angles alike.
pub fn turning_angle(e0: &V3, e1: &V3) -> f64 {
    e0.cross(e1).norm().atan2(e0.dot(e1))
}

/// Discrete curvature binormal `(κb) = 2 e0 × e1 / (|e0||e1| + e0·e1)` (unitless; its
/// magnitude is `2 tan(φ/2)`). Infinite when the rod folds back onto itself (φ = π).
pub fn curvature_binormal(e0: &V3, e1: &V3) -> V3 {
    2.0 * e0.cross(e1) / (e0.norm() * e1.norm() + e0.dot(e1))
}

/// Cross-product matrix `[a]×` with `[a]× b = a × b`.
pub fn cross_matrix(a: &V3) -> M3 {
    M3::new(0.0, -a.z, a.y, a.z, 0.0, -a.x, -a.y, a.x, 0.0)
}

/// Parallel transport of `v` from unit tangent `t0` to unit tangent `t1`: the rotation about
/// `t0 × t1` that takes `t0` to `t1` (the minimal rotation; Bergou 2008 §4.1), applied to `v`.
/// For `t0 = t1` it is the identity; for antiparallel tangents the rotation is undefined and
/// `v` is returned unchanged (callers transport between nearby tangents).
pub fn parallel_transport(v: &V3, t0: &V3, t1: &V3) -> V3 {
    let b = t0.cross(t1);
    let c = t0.dot(t1);
    if 1.0 + c <= f64::EPSILON {
        return *v;
    }
    // Rodrigues' formula with axis b/|b|, cos = c, sin = |b|, written without normalizing b:
    // R v = c v + b × v + (b·v) b / (1 + c).
    c * v + b.cross(v) + b * (b.dot(v) / (1.0 + c))
}

/// An orthonormal frame `(t, d₁, d₂)` attached to an edge.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Frame {
    /// Unit tangent.
    pub t: V3,
    /// First director (⟂ t).
    pub d1: V3,
    /// Second director `t × d₁`.
    pub d2: V3,
}

impl Frame {
    /// A frame with tangent `t` (normalized) and first director the component of `d1_hint`
    /// orthogonal to `t` (normalized). `None` if `t` is zero or `d1_hint ∥ t`.
    pub fn new(t: &V3, d1_hint: &V3) -> Option<Self> {
        let t = tangent(t)?;
        let d1 = d1_hint - t * t.dot(d1_hint);
        let d1 = tangent(&d1)?;
        Some(Self {
            t,
            d1,
            d2: t.cross(&d1),
        })
    }

    /// An arbitrary frame for tangent `t` (for rods without prescribed directors).
    pub fn any_for(t: &V3) -> Option<Self> {
        let t = tangent(t)?;
        let hint = if t.x.abs() < 0.9 { V3::x() } else { V3::y() };
        Self::new(&t, &hint)
    }

    /// This frame parallel-transported to the new tangent `t_new` (time-parallel transport,
    /// Bergou 2010 §5: how reference frames follow an edge from one configuration to the next).
    pub fn transported_to(&self, t_new: &V3) -> Option<Self> {
        let t_new = tangent(t_new)?;
        let d1 = parallel_transport(&self.d1, &self.t, &t_new);
        // Re-orthonormalize against round-off.
        Self::new(&t_new, &d1)
    }

    /// Material directors `(m₁, m₂)` of this reference frame rotated by the twist angle θ (rad)
    /// about the tangent: `m₁ = cos θ d₁ + sin θ d₂`, `m₂ = −sin θ d₁ + cos θ d₂`.
    pub fn material(&self, theta: f64) -> (V3, V3) {
        let (s, c) = theta.sin_cos();
        (c * self.d1 + s * self.d2, -s * self.d1 + c * self.d2)
    }
}

/// Reference twist at the vertex between two edges (rad): the signed angle from the first
/// edge's `d₁`, parallel-transported across the vertex onto the second edge, to the second
/// edge's `d₁`, measured about the second tangent (Bergou 2010, §6). The total twist of the
/// material frame at the vertex is `θ₁ − θ₀ + reference_twist`.
pub fn reference_twist(f0: &Frame, f1: &Frame) -> f64 {
    let moved = parallel_transport(&f0.d1, &f0.t, &f1.t);
    signed_angle(&moved, &f1.d1, &f1.t)
}

/// Signed angle (rad) from `u` to `v` about the axis `n` (both ⟂ n).
pub fn signed_angle(u: &V3, v: &V3, n: &V3) -> f64 {
    let w = u.cross(v);
    w.dot(n).atan2(u.dot(v))
}

/// The cosine `c = a·b / (|a||b|)` of the angle between two vectors with its gradient and
/// Hessian with respect to `(a, b)`:
/// `∇ₐc = (b̂ − c â)/|a|`,
/// `∇²ₐₐc = (3c ââᵀ − â b̂ᵀ − b̂ âᵀ − c I)/|a|²`,
/// `∇²ₐᵦc = (I − ââᵀ − b̂b̂ᵀ + c â b̂ᵀ)/(|a||b|)`.
pub struct CosineDerivatives {
    /// The cosine itself.
    pub c: f64,
    /// ∂c/∂a.
    pub da: V3,
    /// ∂c/∂b.
    pub db: V3,
    /// ∂²c/∂a².
    pub daa: M3,
    /// ∂²c/∂a∂b (row index over a, column over b).
    pub dab: M3,
    /// ∂²c/∂b².
    pub dbb: M3,
}

impl CosineDerivatives {
    /// Evaluates the cosine and its derivatives; requires non-zero `a`, `b`.
    pub fn new(a: &V3, b: &V3) -> Self {
        let (la, lb) = (a.norm(), b.norm());
        let (ah, bh) = (a / la, b / lb);
        let c = ah.dot(&bh);
        let i = M3::identity();
        let aa = ah * ah.transpose();
        let bb = bh * bh.transpose();
        let ab = ah * bh.transpose();
        Self {
            c,
            da: (bh - c * ah) / la,
            db: (ah - c * bh) / lb,
            daa: (3.0 * c * aa - ab - ab.transpose() - c * i) / (la * la),
            dab: (i - aa - bb + c * ab) / (la * lb),
            dbb: (3.0 * c * bb - ab - ab.transpose() - c * i) / (lb * lb),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn curvature_binormal_magnitude_is_two_tan_half_angle() {
        let e0 = V3::new(1.0, 0.0, 0.0);
        for phi in [1e-6f64, 0.3, 1.2, 2.5] {
            let e1 = 0.7 * V3::new(phi.cos(), phi.sin(), 0.0);
            let kb = curvature_binormal(&e0, &e1);
            assert!((kb.norm() - 2.0 * (phi / 2.0).tan()).abs() < 1e-12 * (1.0 + kb.norm()));
            assert!((turning_angle(&e0, &e1) - phi).abs() < 1e-14);
            assert!(kb.z > 0.0);
        }
    }

    #[test]
    fn parallel_transport_maps_tangent_and_preserves_angles() {
        let t0 = V3::new(1.0, 0.2, -0.3).normalize();
        let t1 = V3::new(0.1, 1.0, 0.4).normalize();
        assert!((parallel_transport(&t0, &t0, &t1) - t1).norm() < 1e-14);
        let u = t0.cross(&V3::new(0.3, -0.5, 0.9)).normalize();
        let pu = parallel_transport(&u, &t0, &t1);
        assert!(pu.dot(&t1).abs() < 1e-14);
        assert!((pu.norm() - 1.0).abs() < 1e-14);
        // The binormal t0 × t1 is fixed by the transport.
        let b = t0.cross(&t1);
        assert!((parallel_transport(&b, &t0, &t1) - b).norm() < 1e-14);
    }

    #[test]
    fn reference_twist_of_a_planar_curve_with_transported_frames_is_zero() {
        let e0 = V3::new(1.0, 0.0, 0.0);
        let e1 = V3::new(0.6, 0.8, 0.0);
        let f0 = Frame::new(&e0, &V3::z()).unwrap();
        let f1 = f0.transported_to(&e1).unwrap();
        assert!(reference_twist(&f0, &f1).abs() < 1e-15);
        // Rotating the second frame's director by 0.4 rad shows up as reference twist.
        let (m1, _) = f1.material(0.4);
        let f1r = Frame::new(&e1, &m1).unwrap();
        assert!((reference_twist(&f0, &f1r) - 0.4).abs() < 1e-14);
    }
}
