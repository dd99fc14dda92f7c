//! planView geometry: line, arc, spiral (clothoid), poly3, paramPoly3.
//!
//! Every piece is evaluated from its own start `(x, y, hdg)` — never by
//! chaining end points, since real files have mm–cm gaps between pieces.
//! Spirals and cubic polynomials are integrated with 8-point Gauss–Legendre
//! quadrature on sub-intervals small enough that the integrand is smooth
//! (heading change ≤ 0.05 rad per sub-interval), which is accurate to far
//! below a millimetre over a kilometre; constants are precomputed per piece.

use litesim_core::math;
use serde::{Deserialize, Serialize};

/// `x^1.5` as `x·√x`: a correctly rounded square root and one product, the
/// same bits on every machine (the platform's `pow` is not).
fn pow_three_halves(x: f64) -> f64 {
    x * x.sqrt()
}

/// Gauss–Legendre nodes and weights on [−1, 1], 8 points (published constants).
const GL_X: [f64; 8] = [
    -0.960_289_856_497_536_2,
    -0.796_666_477_413_626_7,
    -0.525_532_409_916_329,
    -0.183_434_642_495_649_8,
    0.183_434_642_495_649_8,
    0.525_532_409_916_329,
    0.796_666_477_413_626_7,
    0.960_289_856_497_536_2,
];
const GL_W: [f64; 8] = [
    0.101_228_536_290_376_3,
    0.222_381_034_453_374_5,
    0.313_706_645_877_887_3,
    0.362_683_783_378_362,
    0.362_683_783_378_362,
    0.313_706_645_877_887_3,
    0.222_381_034_453_374_5,
    0.101_228_536_290_376_3,
];

/// ∫ₐᵇ f with `n` equal sub-intervals of 8-point Gauss–Legendre.
fn integrate(a: f64, b: f64, n: usize, mut f: impl FnMut(f64) -> (f64, f64)) -> (f64, f64) {
    let h = (b - a) / n as f64;
    let (mut sx, mut sy) = (0.0, 0.0);
    for k in 0..n {
        let mid = a + h * (k as f64 + 0.5);
        for (x, w) in GL_X.iter().zip(GL_W) {
            let (fx, fy) = f(mid + 0.5 * h * x);
            sx += w * fx;
            sy += w * fy;
        }
    }
    (sx * 0.5 * h, sy * 0.5 * h)
}

/// The shape of one planView piece.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case", tag = "type")]
pub enum Shape {
    /// Straight line.
    Line,
    /// Constant curvature (1/m, positive turns left).
    Arc {
        /// Curvature.
        curvature: f64,
    },
    /// Curvature linear in arc length.
    Spiral {
        /// Curvature at the start (1/m).
        curv_start: f64,
        /// Curvature at the end (1/m).
        curv_end: f64,
    },
    /// `v(u) = a + b·u + c·u² + d·u³` in the local frame (deprecated in 1.8).
    Poly3 {
        /// Coefficients a, b, c, d.
        coef: [f64; 4],
    },
    /// `u(p)`, `v(p)` cubic in p.
    ParamPoly3 {
        /// aU, bU, cU, dU.
        u: [f64; 4],
        /// aV, bV, cV, dV.
        v: [f64; 4],
        /// p ∈ [0, length] (`arcLength`) or [0, 1] (`normalized`).
        normalized: bool,
    },
}

/// A planView piece with precomputed tables.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Geometry {
    /// Start along the road (m).
    pub s: f64,
    /// Start x (m).
    pub x: f64,
    /// Start y (m).
    pub y: f64,
    /// Start heading (rad).
    pub hdg: f64,
    /// Arc length (m).
    pub length: f64,
    /// The shape.
    pub shape: Shape,
    /// For poly3/paramPoly3/spiral: arc length → (parameter) samples for inversion.
    #[serde(skip)]
    table: Vec<(f64, f64)>,
    /// sin and cos of the start heading, made once (every evaluation needs
    /// them; the road's locator evaluates a few times per vehicle per
    /// step), with the bits of the heading they were made for: a heading
    /// changed since is computed afresh.
    #[serde(skip)]
    start_trig: Option<(u64, f64, f64)>,
}

/// A point of a reference line.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RefPoint {
    /// x (m).
    pub x: f64,
    /// y (m).
    pub y: f64,
    /// Heading (rad).
    pub hdg: f64,
    /// Curvature (1/m).
    pub curvature: f64,
    /// sin and cos of `hdg` when the evaluation had them at hand (lines
    /// and arcs): [`RefPoint::sin_cos`] then costs nothing. Kept with the
    /// bits of the heading they belong to (a caller may turn `hdg`).
    trig: Option<(u64, f64, f64)>,
}

impl RefPoint {
    /// sin and cos of the heading: the same bits as `math::sin_cos(hdg)`.
    #[inline]
    pub fn sin_cos(&self) -> (f64, f64) {
        match self.trig {
            Some((bits, sh, ch)) if bits == self.hdg.to_bits() => (sh, ch),
            _ => math::sin_cos(self.hdg),
        }
    }
}

fn poly(c: &[f64; 4], p: f64) -> f64 {
    c[0] + p * (c[1] + p * (c[2] + p * c[3]))
}
fn dpoly(c: &[f64; 4], p: f64) -> f64 {
    c[1] + p * (2.0 * c[2] + 3.0 * p * c[3])
}
fn ddpoly(c: &[f64; 4], p: f64) -> f64 {
    2.0 * c[2] + 6.0 * p * c[3]
}

impl Geometry {
    /// A piece; builds the tables the shape needs.
    pub fn new(s: f64, x: f64, y: f64, hdg: f64, length: f64, shape: Shape) -> Self {
        let mut g = Self {
            s,
            x,
            y,
            hdg,
            length,
            shape,
            table: Vec::new(),
            start_trig: None,
        };
        g.build_table();
        let (sh, ch) = math::sin_cos(hdg);
        g.start_trig = Some((hdg.to_bits(), sh, ch));
        g
    }

    /// sin and cos of the start heading (the same bits as
    /// `math::sin_cos(self.hdg)`).
    #[inline]
    fn start_sin_cos(&self) -> (f64, f64) {
        match self.start_trig {
            Some((bits, sh, ch)) if bits == self.hdg.to_bits() => (sh, ch),
            _ => math::sin_cos(self.hdg),
        }
    }

    /// Arc-length table for poly3 (u) and paramPoly3 (p): 64 intervals, each
    /// integrated with Gauss–Legendre; inverted by Newton from the table.
    fn build_table(&mut self) {
        let speed: Box<dyn Fn(f64) -> f64> = match &self.shape {
            Shape::Poly3 { coef } => {
                let c = *coef;
                Box::new(move |u| (1.0 + dpoly(&c, u).powi(2)).sqrt())
            }
            Shape::ParamPoly3 { u, v, .. } => {
                let (u, v) = (*u, *v);
                Box::new(move |p| (dpoly(&u, p).powi(2) + dpoly(&v, p).powi(2)).sqrt())
            }
            _ => return,
        };
        // Parameter range: for poly3, u runs a little less than the arc length;
        // extend until the arc length is covered.
        let p_end = match &self.shape {
            Shape::ParamPoly3 {
                normalized: true, ..
            } => 1.0,
            Shape::ParamPoly3 { .. } => self.length,
            _ => self.length,
        };
        let n = 64;
        let mut table = Vec::with_capacity(n + 1);
        let (mut s, mut p) = (0.0, 0.0);
        table.push((0.0, 0.0));
        let h = p_end.max(1e-9) / n as f64;
        for _ in 0..n {
            let (ds, _) = integrate(p, p + h, 1, |q| (speed(q), 0.0));
            s += ds;
            p += h;
            table.push((s, p));
        }
        self.table = table;
    }

    /// The parameter at arc length `ds` (poly3: u; paramPoly3: p).
    fn param_at(&self, ds: f64) -> f64 {
        let t = &self.table;
        if t.len() < 2 {
            return ds;
        }
        let i = t.partition_point(|(s, _)| *s <= ds).clamp(1, t.len() - 1);
        let (s0, p0) = t[i - 1];
        let (s1, p1) = t[i];
        // Linear guess, then two Newton steps on s(p) − ds with s'(p) = speed.
        let mut p = if s1 > s0 {
            p0 + (p1 - p0) * (ds - s0) / (s1 - s0)
        } else {
            p0
        };
        for _ in 0..2 {
            let (s_p, _) = integrate(p0, p, 1, |q| (self.speed_at(q), 0.0));
            let sp = self.speed_at(p);
            if sp > 1e-12 {
                p -= (s0 + s_p - ds) / sp;
            }
        }
        p
    }

    fn speed_at(&self, p: f64) -> f64 {
        match &self.shape {
            Shape::Poly3 { coef } => (1.0 + dpoly(coef, p).powi(2)).sqrt(),
            Shape::ParamPoly3 { u, v, .. } => (dpoly(u, p).powi(2) + dpoly(v, p).powi(2)).sqrt(),
            _ => 1.0,
        }
    }

    /// Evaluates at `ds` ∈ [0, length] from the piece's start (clamped).
    pub fn eval(&self, ds: f64) -> RefPoint {
        let ds = ds.clamp(0.0, self.length);
        let (sh, ch) = self.start_sin_cos();
        match &self.shape {
            Shape::Line => RefPoint {
                x: self.x + ds * ch,
                y: self.y + ds * sh,
                hdg: self.hdg,
                curvature: 0.0,
                trig: Some((self.hdg.to_bits(), sh, ch)),
            },
            Shape::Arc { curvature: k } => arc(self.x, self.y, (self.hdg, sh, ch), *k, ds),
            Shape::Spiral {
                curv_start,
                curv_end,
            } => {
                let c = if self.length > 0.0 {
                    (curv_end - curv_start) / self.length
                } else {
                    0.0
                };
                if c.abs() < 1e-12 {
                    return arc(self.x, self.y, (self.hdg, sh, ch), *curv_start, ds);
                }
                let k0 = *curv_start;
                let heading = |t: f64| self.hdg + k0 * t + 0.5 * c * t * t;
                // Sub-intervals so that the heading changes ≤ 0.05 rad in each.
                let dh = (k0.abs() + 0.5 * c.abs() * ds) * ds;
                let n = ((dh / 0.05).ceil() as usize).clamp(1, 10_000);
                let (ix, iy) = integrate(0.0, ds, n, |t| {
                    let (s, c) = math::sin_cos(heading(t));
                    (c, s)
                });
                RefPoint {
                    x: self.x + ix,
                    y: self.y + iy,
                    hdg: heading(ds),
                    curvature: k0 + c * ds,
                    trig: None,
                }
            }
            Shape::Poly3 { coef } => {
                let u = self.param_at(ds);
                let v = poly(coef, u);
                let dv = dpoly(coef, u);
                RefPoint {
                    x: self.x + u * ch - v * sh,
                    y: self.y + u * sh + v * ch,
                    hdg: self.hdg + math::atan(dv),
                    curvature: ddpoly(coef, u) / pow_three_halves(1.0 + dv * dv),
                    trig: None,
                }
            }
            Shape::ParamPoly3 { u: cu, v: cv, .. } => {
                let p = self.param_at(ds);
                let (u, v) = (poly(cu, p), poly(cv, p));
                let (du, dv) = (dpoly(cu, p), dpoly(cv, p));
                let (ddu, ddv) = (ddpoly(cu, p), ddpoly(cv, p));
                let n2 = du * du + dv * dv;
                RefPoint {
                    x: self.x + u * ch - v * sh,
                    y: self.y + u * sh + v * ch,
                    hdg: self.hdg + math::atan2(dv, du),
                    curvature: if n2 > 0.0 {
                        (du * ddv - dv * ddu) / pow_three_halves(n2)
                    } else {
                        0.0
                    },
                    trig: None,
                }
            }
        }
    }
}

/// The arc from (x0, y0) at heading h0 (with its sine and cosine) of
/// curvature `k`, `ds` along.
fn arc(x0: f64, y0: f64, (h0, s0, c0): (f64, f64, f64), k: f64, ds: f64) -> RefPoint {
    if k.abs() < 1e-12 {
        return RefPoint {
            x: x0 + ds * c0,
            y: y0 + ds * s0,
            hdg: h0,
            curvature: 0.0,
            trig: Some((h0.to_bits(), s0, c0)),
        };
    }
    let h = h0 + k * ds;
    let (s, c) = math::sin_cos(h);
    RefPoint {
        x: x0 + (s - s0) / k,
        y: y0 - (c - c0) / k,
        hdg: h,
        curvature: k,
        trig: Some((h.to_bits(), s, c)),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::PI;

    #[test]
    fn line_and_arc_closed_forms() {
        let g = Geometry::new(0.0, 1.0, 2.0, PI / 2.0, 10.0, Shape::Line);
        let p = g.eval(4.0);
        assert!((p.x - 1.0).abs() < 1e-12 && (p.y - 6.0).abs() < 1e-12);
        // Quarter circle of radius 10 to the left.
        let g = Geometry::new(
            0.0,
            0.0,
            0.0,
            0.0,
            10.0 * PI / 2.0,
            Shape::Arc { curvature: 0.1 },
        );
        let p = g.eval(10.0 * PI / 2.0);
        assert!(
            (p.x - 10.0).abs() < 1e-9
                && (p.y - 10.0).abs() < 1e-9
                && (p.hdg - PI / 2.0).abs() < 1e-12
        );
    }

    /// Fresnel integrals by their power series (a closed form, summed to
    /// convergence): C(z) = Σ (−1)ⁿ (π/2)²ⁿ z⁴ⁿ⁺¹ / ((2n)! (4n+1)), and
    /// S(z) = Σ (−1)ⁿ (π/2)²ⁿ⁺¹ z⁴ⁿ⁺³ / ((2n+1)! (4n+3)).
    fn fresnel(z: f64) -> (f64, f64) {
        let (mut c, mut s) = (0.0, 0.0);
        let a = PI / 2.0;
        let mut fact = 1.0; // (k)!
        for k in 0..60 {
            if k > 0 {
                fact *= k as f64;
            }
            let term = a.powi(k) * z.powi(2 * k + 1) / (fact * (2 * k + 1) as f64);
            match k % 4 {
                0 => c += term,
                1 => s += term,
                2 => c -= term,
                _ => s -= term,
            }
        }
        (c, s)
    }

    #[test]
    fn spiral_matches_fresnel_to_a_tenth_of_a_millimetre_over_a_kilometre() {
        // Clothoid from curvature 0 to 0.004 over 1000 m: κ = c·s, θ = c s²/2,
        // x = a·C(s/a), y = a·S(s/a) with a = sqrt(π/c).
        let (l, k1) = (1000.0, 0.004);
        let c = k1 / l;
        let a = (PI / c).sqrt();
        let g = Geometry::new(
            0.0,
            0.0,
            0.0,
            0.0,
            l,
            Shape::Spiral {
                curv_start: 0.0,
                curv_end: k1,
            },
        );
        for s in [0.0, 100.0, 333.3, 700.0, 1000.0] {
            let p = g.eval(s);
            let (fc, fs) = fresnel(s / a);
            let (x, y) = (a * fc, a * fs);
            assert!(
                (p.x - x).abs() < 1e-4 && (p.y - y).abs() < 1e-4,
                "s={s}: ({}, {}) vs ({x}, {y})",
                p.x,
                p.y
            );
            assert!((p.hdg - c * s * s / 2.0).abs() < 1e-12);
        }
        // End heading for κ0 = 0: h0 + κ1·L/2.
        assert!((g.eval(l).hdg - k1 * l / 2.0).abs() < 1e-12);
    }

    #[test]
    fn spiral_with_equal_curvatures_is_an_arc() {
        let g = Geometry::new(
            0.0,
            0.0,
            0.0,
            0.0,
            50.0,
            Shape::Spiral {
                curv_start: 0.02,
                curv_end: 0.02,
            },
        );
        let a = Geometry::new(0.0, 0.0, 0.0, 0.0, 50.0, Shape::Arc { curvature: 0.02 });
        assert_eq!(g.eval(30.0), a.eval(30.0));
    }

    #[test]
    fn param_poly3_straight_line_in_both_ranges() {
        // u = p, v = 0 over 20 m, arcLength; and u = 20 p normalized.
        let g = Geometry::new(
            0.0,
            0.0,
            0.0,
            0.0,
            20.0,
            Shape::ParamPoly3 {
                u: [0.0, 1.0, 0.0, 0.0],
                v: [0.0; 4],
                normalized: false,
            },
        );
        let p = g.eval(7.0);
        assert!((p.x - 7.0).abs() < 1e-9 && p.y.abs() < 1e-12);
        let g = Geometry::new(
            0.0,
            0.0,
            0.0,
            0.0,
            20.0,
            Shape::ParamPoly3 {
                u: [0.0, 20.0, 0.0, 0.0],
                v: [0.0; 4],
                normalized: true,
            },
        );
        let p = g.eval(7.0);
        assert!((p.x - 7.0).abs() < 1e-9);
    }

    #[test]
    fn param_poly3_circle_approximation_has_unit_speed_arc_length() {
        // A parabola v = 0.01 u² as paramPoly3; check that eval(ds) lies ds along the curve.
        let g = Geometry::new(
            0.0,
            0.0,
            0.0,
            0.0,
            30.0,
            Shape::ParamPoly3 {
                u: [0.0, 1.0, 0.0, 0.0],
                v: [0.0, 0.0, 0.01, 0.0],
                normalized: false,
            },
        );
        let mut prev = g.eval(0.0);
        let mut len = 0.0;
        for i in 1..=3000 {
            let p = g.eval(i as f64 * 0.01);
            len += ((p.x - prev.x).powi(2) + (p.y - prev.y).powi(2)).sqrt();
            prev = p;
        }
        assert!((len - 30.0).abs() < 1e-3, "{len}");
        // Curvature at p = 0: 2c = 0.02.
        assert!((g.eval(0.0).curvature - 0.02).abs() < 1e-9);
    }

    #[test]
    fn poly3_matches_its_polynomial() {
        let coef = [0.0, 0.0, 0.002, -0.00001];
        let g = Geometry::new(0.0, 5.0, 5.0, 0.3, 40.0, Shape::Poly3 { coef });
        let p = g.eval(40.0);
        // Undo the rotation and check v(u) = poly(u).
        let (dx, dy) = (p.x - 5.0, p.y - 5.0);
        let (u, v) = (
            dx * 0.3f64.cos() + dy * 0.3f64.sin(),
            -dx * 0.3f64.sin() + dy * 0.3f64.cos(),
        );
        assert!((v - poly(&coef, u)).abs() < 1e-9);
        assert!(u < 40.0 && u > 39.0);
    }
}
