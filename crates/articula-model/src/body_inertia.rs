//! Validation and repair of the bodies' rotational inertias, after fixed-joint merging (what
//! dynamics sees), with tolerances in each body's own scale (`docs/loading.md`).
//!
//! A body of mass `m` with rotational inertia `I_c` about its centre of mass has principal
//! moments `λ1 ≤ λ2 ≤ λ3` (the eigenvalues of `I_c`). A rigid body has `λ1 ≥ 0` and
//! `λ3 ≤ λ1 + λ2` (the triangle inequality: `I_c = tr(Σ) 1 − Σ` for a second moment of mass
//! `Σ ⪰ 0`). Its scale is `s = max(λ3, m ℓ²)`, `ℓ` the body's size (the largest distance from its
//! centre of mass to its frame or to the frame of a link merged into it, at least 1 mm).

use crate::options::InertiaPolicy;
use articula_spatial::SpatialInertia;
use glam::{DMat3, DVec3};
use std::fmt;

/// Round-off tolerance, relative to the body's scale `s`: a moment below zero, or a triangle
/// excess, of at most `TOLERANCE · s` is not a defect. URDF inertias are printed with about six
/// significant digits, so entries carry round-off up to ~5e-7 of the largest.
pub const TOLERANCE: f64 = 1e-6;

/// A body whose smallest principal moment is at most `SINGULAR · s` is a point or rod mass: its
/// spatial inertia is singular to working precision. [`InertiaPolicy::Accept`] loads it as
/// written (with a warning): ABA and CRBA never invert a body's inertia, and the
/// divide-and-conquer algorithm, which does, inverts a regularised copy and refines its result
/// against the exact inertias (`articula-dca`, `docs/loading.md`), so dynamics stays exact.
/// [`InertiaPolicy::Repair`] raises such a body's small moments to `SINGULAR · s` (a change of
/// the dynamics of relative size ~1e-9 of the body's scale, more where a joint axis passes
/// close to a point mass); [`InertiaPolicy::Strict`] refuses it.
pub const SINGULAR: f64 = 1e-9;

/// [`InertiaPolicy::Repair`] raises a mass of zero (a massless body with a rotational inertia)
/// to this fraction of the largest body mass of the model.
pub const MASS_FLOOR: f64 = 1e-6;

/// The smallest body size used for the scale (1 mm).
pub const MIN_SIZE: f64 = 1e-3;

/// Eigenvalues (ascending) and unit eigenvectors (the matching columns) of a symmetric 3×3
/// matrix, by cyclic Jacobi rotations (accurate to rounding for every symmetric input).
pub fn principal_moments(m: DMat3) -> ([f64; 3], DMat3) {
    let mut a = [[0.0; 3]; 3];
    for (i, row) in a.iter_mut().enumerate() {
        for (j, x) in row.iter_mut().enumerate() {
            // Symmetrised, so an input asymmetric by rounding is read as its symmetric part.
            *x = 0.5 * (m.col(j)[i] + m.col(i)[j]);
        }
    }
    let mut v = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
    for _sweep in 0..64 {
        let off = a[0][1].abs() + a[0][2].abs() + a[1][2].abs();
        let diag = a[0][0].abs() + a[1][1].abs() + a[2][2].abs();
        if off == 0.0 || off <= f64::EPSILON * 1e-3 * diag {
            break;
        }
        for (p, q) in [(0, 1), (0, 2), (1, 2)] {
            if a[p][q] == 0.0 {
                continue;
            }
            let theta = (a[q][q] - a[p][p]) / (2.0 * a[p][q]);
            let t = theta.signum() / (theta.abs() + (theta * theta + 1.0).sqrt());
            // theta = ±inf (a[p][q] negligible): t = 0.
            let t = if t.is_finite() { t } else { 0.0 };
            let c = 1.0 / (t * t + 1.0).sqrt();
            let s = t * c;
            // A ← Jᵀ A J with the rotation J in the (p, q) plane: columns, then rows.
            for row in &mut a {
                let (akp, akq) = (row[p], row[q]);
                row[p] = c * akp - s * akq;
                row[q] = s * akp + c * akq;
            }
            let (rp, rq) = (a[p], a[q]);
            for k in 0..3 {
                a[p][k] = c * rp[k] - s * rq[k];
                a[q][k] = s * rp[k] + c * rq[k];
            }
            for row in &mut v {
                let (vp, vq) = (row[p], row[q]);
                row[p] = c * vp - s * vq;
                row[q] = s * vp + c * vq;
            }
        }
    }
    let mut order = [0usize, 1, 2];
    order.sort_by(|&i, &j| a[i][i].total_cmp(&a[j][j]));
    let moments = order.map(|i| a[i][i]);
    let col = |i: usize| DVec3::new(v[0][i], v[1][i], v[2][i]);
    let axes = DMat3::from_cols(col(order[0]), col(order[1]), col(order[2]));
    (moments, axes)
}

/// Which condition a body's inertia breaks.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum InertiaDefectKind {
    /// `λ1 < 0` beyond the tolerance: the inertia is indefinite (no body has it).
    NotPositive,
    /// `λ3 > λ1 + λ2` beyond the tolerance.
    TriangleInequality,
    /// `λ1 ≈ 0` (within [`SINGULAR`] of the scale) with a positive mass: a point or rod mass,
    /// singular for the divide-and-conquer algorithm.
    Singular,
    /// Zero mass with a rotational inertia.
    MasslessWithInertia,
    /// A mass below [`crate::LoadOptions::bound_mass`]: not a defect of the body, a floor the
    /// loader was asked for (reported by [`InertiaPolicy::Repair`] with that bound only).
    MassBelowBound,
    /// A principal moment below [`crate::LoadOptions::bound_inertia`] (likewise).
    InertiaBelowBound,
}

/// One broken condition of one body, with its numbers.
#[derive(Clone, Debug, PartialEq)]
pub struct InertiaDefect {
    /// The body (its URDF link).
    pub body: String,
    /// The URDF links merged into it, its own first.
    pub links: Vec<String>,
    /// Its mass (kg).
    pub mass: f64,
    /// Principal moments about its centre of mass, ascending (kg·m²).
    pub moments: [f64; 3],
    /// The condition broken.
    pub kind: InertiaDefectKind,
    /// By how much (kg·m²): `−λ1` for [`InertiaDefectKind::NotPositive`], `λ3 − λ1 − λ2` for
    /// the triangle inequality, `λ1` for a singular body, `λ3` for a massless one; for the
    /// bounds, the bound (kg for [`InertiaDefectKind::MassBelowBound`]).
    pub by: f64,
    /// The body's round-off tolerance `TOLERANCE · s` (kg·m²).
    pub tolerance: f64,
}

fn fmt_moments(m: &[f64; 3]) -> String {
    format!("[{:.6e}, {:.6e}, {:.6e}]", m[0], m[1], m[2])
}

impl fmt::Display for InertiaDefect {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let [l1, l2, l3] = self.moments;
        write!(
            f,
            "body '{}' (mass {} kg, principal moments {} kg·m² about its centre of mass",
            self.body,
            crate::error::number(self.mass),
            fmt_moments(&self.moments)
        )?;
        if self.links.len() > 1 {
            write!(f, ", links {}", self.links.join(", "))?;
        }
        write!(f, "): ")?;
        match self.kind {
            InertiaDefectKind::NotPositive => write!(
                f,
                "not positive semidefinite: λ1 = {l1:.6e} < 0 by {:.3e} (tolerance {:.3e})",
                self.by, self.tolerance
            ),
            InertiaDefectKind::TriangleInequality => write!(
                f,
                "breaks the triangle inequality λ3 ≤ λ1 + λ2: {l3:.6e} > {l1:.6e} + {l2:.6e} by \
                 {:.3e} ({:.3}% of λ3; tolerance {:.3e})",
                self.by,
                100.0 * self.by / l3,
                self.tolerance
            ),
            InertiaDefectKind::Singular => write!(
                f,
                "a point or rod mass: λ1 = {l1:.3e} is zero to working precision (≤ {:.3e}), so \
                 its spatial inertia is singular",
                SINGULAR / TOLERANCE * self.tolerance
            ),
            InertiaDefectKind::MasslessWithInertia => {
                write!(f, "massless with a rotational inertia (λ3 = {l3:.6e})")
            }
            InertiaDefectKind::MassBelowBound => {
                write!(f, "mass below bound_mass {:e} kg", self.by)
            }
            InertiaDefectKind::InertiaBelowBound => {
                write!(f, "λ1 = {l1:.3e} below bound_inertia {:e} kg·m²", self.by)
            }
        }
    }
}

/// A body's inertia before and after a change by the loader.
#[derive(Clone, Debug, PartialEq)]
pub struct InertiaChange {
    /// What was wrong.
    pub defects: Vec<InertiaDefect>,
    /// Mass after (kg).
    pub mass: f64,
    /// Principal moments after, ascending (kg·m²).
    pub moments: [f64; 3],
    /// What was done: `boundmass`, `boundinertia`, `balanceinertia`.
    pub fixes: Vec<&'static str>,
}

impl fmt::Display for InertiaChange {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let d = &self.defects[0];
        write!(f, "body '{}': {} changed ", d.body, self.fixes.join(" + "))?;
        if d.mass != self.mass {
            write!(
                f,
                "mass {} → {} kg, ",
                crate::error::number(d.mass),
                crate::error::number(self.mass)
            )?;
        } else {
            write!(f, "(mass {} kg) ", crate::error::number(d.mass))?;
        }
        write!(
            f,
            "principal moments {} → {} kg·m² (",
            fmt_moments(&d.moments),
            fmt_moments(&self.moments)
        )?;
        let kinds: Vec<String> = self
            .defects
            .iter()
            .map(|d| match d.kind {
                InertiaDefectKind::NotPositive => "not positive semidefinite".to_string(),
                InertiaDefectKind::TriangleInequality => "triangle inequality broken".to_string(),
                InertiaDefectKind::Singular => "point or rod mass".to_string(),
                InertiaDefectKind::MasslessWithInertia => {
                    "massless with rotational inertia".to_string()
                }
                InertiaDefectKind::MassBelowBound => format!("below bound_mass {:e} kg", d.by),
                InertiaDefectKind::InertiaBelowBound => {
                    format!("below bound_inertia {:e} kg·m²", d.by)
                }
            })
            .collect();
        write!(f, "{})", kinds.join(", "))
    }
}

/// A body's inertia under scrutiny.
pub(crate) struct BodyInertia<'a> {
    pub name: &'a str,
    pub links: Vec<String>,
    pub inertia: SpatialInertia,
    /// The body's size ℓ before the [`MIN_SIZE`] floor.
    pub size: f64,
}

/// The outcome of checking one body under a policy.
pub(crate) enum Verdict {
    /// Nothing odd.
    Fine,
    /// Loaded as written, with these defects reported as a warning.
    Odd(Vec<InertiaDefect>),
    /// Loaded with this new inertia (and the change reported).
    Changed(SpatialInertia, InertiaChange),
    /// Refused for these defects.
    Refused(Vec<InertiaDefect>),
}

impl BodyInertia<'_> {
    fn scale(&self, mass: f64, moments: &[f64; 3]) -> f64 {
        let size = self.size.max(MIN_SIZE);
        moments[2]
            .abs()
            .max(moments[0].abs())
            .max(mass * size * size)
    }

    /// A defect of kind `kind` (by `by`) of this body, of mass `m` and principal moments
    /// `moments`, with its round-off tolerance `TOLERANCE · s`.
    fn defect(&self, m: f64, moments: [f64; 3], kind: InertiaDefectKind, by: f64) -> InertiaDefect {
        InertiaDefect {
            body: self.name.to_string(),
            links: self.links.clone(),
            mass: m,
            moments,
            kind,
            by,
            tolerance: TOLERANCE * self.scale(m, &moments),
        }
    }

    /// Every condition the body breaks.
    pub fn defects(&self) -> Vec<InertiaDefect> {
        let m = self.inertia.mass;
        let (moments, _) = principal_moments(self.inertia.inertia_about_com());
        let [l1, l2, l3] = moments;
        let s = self.scale(m, &moments);
        let tolerance = TOLERANCE * s;
        let defect = |kind, by| self.defect(m, moments, kind, by);
        let mut out = Vec::new();
        if m == 0.0 {
            // On the entries: moments of a huge inertia may overflow to NaN.
            let ic = self.inertia.inertia_about_com().to_cols_array();
            let largest = ic.iter().fold(0.0f64, |a, x| a.max(x.abs()));
            if largest > 0.0 || ic.iter().any(|x| x.is_nan()) {
                out.push(defect(InertiaDefectKind::MasslessWithInertia, largest));
            }
            return out;
        }
        if l1 < -tolerance {
            out.push(defect(InertiaDefectKind::NotPositive, -l1));
        } else if l1 <= SINGULAR * s {
            out.push(defect(InertiaDefectKind::Singular, l1));
        }
        if l3 - l1 - l2 > tolerance {
            out.push(defect(InertiaDefectKind::TriangleInequality, l3 - l1 - l2));
        }
        out
    }

    /// Every absolute bound the body is below: `bound_mass` (kg) and `bound_inertia` (kg·m²),
    /// 0 for none. A bound of 0 names no defect: a negative moment is `NotPositive`, not below
    /// a bound nobody gave.
    fn below_bounds(&self, bound_mass: f64, bound_inertia: f64) -> Vec<InertiaDefect> {
        let m = self.inertia.mass;
        let (moments, _) = principal_moments(self.inertia.inertia_about_com());
        let defect = |kind, by| self.defect(m, moments, kind, by);
        let mut out = Vec::new();
        if bound_mass > 0.0 && m < bound_mass {
            out.push(defect(InertiaDefectKind::MassBelowBound, bound_mass));
        }
        if bound_inertia > 0.0 && moments[0] < bound_inertia {
            out.push(defect(InertiaDefectKind::InertiaBelowBound, bound_inertia));
        }
        out
    }

    /// Applies `policy` (`max_mass`: the largest body mass of the model, for `boundmass`;
    /// `bounds`: the absolute `(bound_mass, bound_inertia)` of [`InertiaPolicy::Repair`], 0 for
    /// none).
    pub fn judge(&self, policy: InertiaPolicy, max_mass: f64, bounds: (f64, f64)) -> Verdict {
        let mut defects = self.defects();
        if policy == InertiaPolicy::Repair {
            defects.extend(self.below_bounds(bounds.0, bounds.1));
        }
        if defects.is_empty() {
            return Verdict::Fine;
        }
        let has = |k| defects.iter().any(|d| d.kind == k);
        match policy {
            InertiaPolicy::Strict => Verdict::Refused(defects),
            InertiaPolicy::Accept => {
                if has(InertiaDefectKind::NotPositive)
                    || has(InertiaDefectKind::MasslessWithInertia)
                {
                    Verdict::Refused(
                        defects
                            .into_iter()
                            .filter(|d| {
                                matches!(
                                    d.kind,
                                    InertiaDefectKind::NotPositive
                                        | InertiaDefectKind::MasslessWithInertia
                                )
                            })
                            .collect(),
                    )
                } else {
                    // A point or rod mass too stays as written (see [`SINGULAR`]).
                    Verdict::Odd(defects)
                }
            }
            InertiaPolicy::Repair => {
                let (inertia, change) = self.repair(defects, max_mass, bounds);
                Verdict::Changed(inertia, change)
            }
        }
    }

    /// `boundmass` (a zero mass raised to `MASS_FLOOR · max_mass`, then every mass to at
    /// least the absolute `bound_mass`), `boundinertia` (a point or rod mass's moments raised
    /// to `SINGULAR · s`, then every moment to at least the absolute `bound_inertia`) and
    /// `balanceinertia` (the two smaller moments raised by half the triangle excess each, so
    /// that `λ3 = λ1 + λ2`: the least change, where MuJoCo sets all three to their mean).
    /// Principal axes and centre of mass are kept; the rotational inertia is not scaled with a
    /// raised mass (as in MuJoCo).
    fn repair(
        &self,
        defects: Vec<InertiaDefect>,
        max_mass: f64,
        (bound_mass, bound_inertia): (f64, f64),
    ) -> (SpatialInertia, InertiaChange) {
        let mut fixes = Vec::new();
        let mut m = self.inertia.mass;
        let com = self.inertia.com();
        let (mut moments, axes) = principal_moments(self.inertia.inertia_about_com());
        if m == 0.0 {
            m = MASS_FLOOR * if max_mass > 0.0 { max_mass } else { 1.0 };
        }
        if m < bound_mass {
            m = bound_mass;
        }
        if m != self.inertia.mass {
            fixes.push("boundmass");
        }
        let relative = SINGULAR * self.scale(m, &moments);
        let singular = moments[0] <= relative;
        if singular || moments[0] < bound_inertia {
            let floor = if singular {
                relative.max(bound_inertia)
            } else {
                bound_inertia
            };
            for x in &mut moments {
                *x = x.max(floor);
            }
            fixes.push("boundinertia");
        }
        let excess = moments[2] - moments[0] - moments[1];
        if excess > 0.0 {
            moments[0] += 0.5 * excess;
            moments[1] += 0.5 * excess;
            fixes.push("balanceinertia");
        }
        let ic = axes * DMat3::from_diagonal(DVec3::from_array(moments)) * axes.transpose();
        let inertia = SpatialInertia::new(m, com, ic);
        let (after, _) = principal_moments(ic);
        (
            inertia,
            InertiaChange {
                defects,
                mass: m,
                moments: after,
                fixes,
            },
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn principal_moments_of_a_rotated_diagonal() {
        let r = DMat3::from_euler(glam::EulerRot::ZYX, 0.3, -1.1, 2.0);
        let d = DMat3::from_diagonal(DVec3::new(3.0, -1.0, 2.0));
        let (moments, axes) = principal_moments(r * d * r.transpose());
        for (got, want) in moments.iter().zip([-1.0, 2.0, 3.0]) {
            assert!((got - want).abs() < 1e-14, "{moments:?}");
        }
        let back = axes * DMat3::from_diagonal(DVec3::from_array(moments)) * axes.transpose();
        let err = (back - r * d * r.transpose())
            .to_cols_array()
            .iter()
            .fold(0.0f64, |m, x| m.max(x.abs()));
        assert!(err < 1e-14, "{err}");
        // Orthonormal axes.
        let e = (axes.transpose() * axes - DMat3::IDENTITY)
            .to_cols_array()
            .iter()
            .fold(0.0f64, |m, x| m.max(x.abs()));
        assert!(e < 1e-14, "{e}");
    }

    fn body(mass: f64, com: DVec3, ic: DMat3, size: f64) -> BodyInertia<'static> {
        BodyInertia {
            name: "head",
            links: vec!["head".to_string()],
            inertia: SpatialInertia::new(mass, com, ic),
            size,
        }
    }

    fn max_abs(m: DMat3) -> f64 {
        m.to_cols_array().iter().fold(0.0f64, |a, x| a.max(x.abs()))
    }

    /// `Changed` or a panic naming the verdict.
    fn changed(v: Verdict) -> (SpatialInertia, InertiaChange) {
        match v {
            Verdict::Changed(i, c) => (i, c),
            Verdict::Fine => panic!("fine"),
            Verdict::Odd(d) | Verdict::Refused(d) => panic!("not changed: {d:?}"),
        }
    }

    #[test]
    fn bound_inertia_raises_a_point_mass_to_the_bound() {
        // icub's head: 1.34 kg, no rotational inertia, the centre of mass 0.4 mm from its frame.
        let com = DVec3::new(4e-4, 0.0, 0.0);
        let head = body(1.34, com, DMat3::ZERO, com.length());
        let b = 1e-4;
        let (inertia, change) = changed(head.judge(InertiaPolicy::Repair, 1.34, (0.0, b)));
        // max(0, b) for each moment, the mass and centre of mass kept.
        assert_eq!(change.moments, [b; 3]);
        assert_eq!(change.mass, 1.34);
        assert_eq!(change.fixes, vec!["boundinertia"]);
        let kinds: Vec<_> = change.defects.iter().map(|d| d.kind).collect();
        assert_eq!(
            kinds,
            [
                InertiaDefectKind::Singular,
                InertiaDefectKind::InertiaBelowBound
            ]
        );
        assert_eq!(inertia.mass, 1.34);
        assert!((inertia.com() - com).length() < 1e-18);
        let err = max_abs(inertia.inertia_about_com() - DMat3::from_diagonal(DVec3::splat(b)));
        assert!(err < 1e-18, "{err}");
        // The warning names the bound and the numbers before and after.
        let text = change.to_string();
        assert!(text.contains("below bound_inertia 1e-4 kg·m²"), "{text}");
        assert!(
            text.contains("→ [1.000000e-4, 1.000000e-4, 1.000000e-4]"),
            "{text}"
        );
        // Without the bound: the relative floor 1e-9 · m ℓ² (ℓ = 1 mm, the smallest size).
        let (_, change) = changed(head.judge(InertiaPolicy::Repair, 1.34, (0.0, 0.0)));
        assert_eq!(change.moments, [1e-9 * 1.34 * 1e-6; 3]);
        // Accept and Strict never apply a bound.
        assert!(matches!(
            head.judge(InertiaPolicy::Accept, 1.34, (0.0, b)),
            Verdict::Odd(d) if d.len() == 1
        ));
    }

    #[test]
    fn repair_without_bounds_names_no_bound() {
        // romeo_laas_small's LHipPitch_link: a negative principal moment, repaired with no
        // absolute bound given. The warning names what is wrong with it, not a bound of 0.
        let com = DVec3::new(0.0, 0.01, -0.05);
        let ic = DMat3::from_diagonal(DVec3::new(-2.720418e-3, 3.951261e-2, 5.404991e-2));
        let hip = body(4.71096, com, ic, 0.3);
        let (_, change) = changed(hip.judge(InertiaPolicy::Repair, 4.71096, (0.0, 0.0)));
        let kinds: Vec<_> = change.defects.iter().map(|d| d.kind).collect();
        assert_eq!(
            kinds,
            [
                InertiaDefectKind::NotPositive,
                InertiaDefectKind::TriangleInequality
            ]
        );
        let text = change.to_string();
        assert!(
            text.ends_with("(not positive semidefinite, triangle inequality broken)"),
            "{text}"
        );
        assert!(!text.contains("bound_"), "{text}");
    }

    #[test]
    fn bound_inertia_keeps_axes_and_larger_moments() {
        // A rotated body with moments 5e-5, 2e-4, 2.2e-4: only the smallest is below 1e-4.
        let r = DMat3::from_euler(glam::EulerRot::ZYX, 0.7, -0.4, 1.9);
        let ic = r * DMat3::from_diagonal(DVec3::new(2e-4, 5e-5, 2.2e-4)) * r.transpose();
        let com = DVec3::new(0.01, -0.02, 0.03);
        let b = 1e-4;
        let link = body(0.5, com, ic, 0.05);
        assert!(link.defects().is_empty());
        assert!(matches!(
            link.judge(InertiaPolicy::Repair, 0.5, (0.0, 0.0)),
            Verdict::Fine
        ));
        let (inertia, change) = changed(link.judge(InertiaPolicy::Repair, 0.5, (0.0, b)));
        for (got, want) in change.moments.iter().zip([b, 2e-4, 2.2e-4]) {
            assert!((got - want).abs() < 1e-18, "{:?}", change.moments);
        }
        assert!((inertia.com() - com).length() < 1e-17);
        // The same principal axes: r's columns are eigenvectors of the new inertia.
        let new = inertia.inertia_about_com();
        for (i, want) in [2e-4, b, 2.2e-4].into_iter().enumerate() {
            let v = r.col(i);
            assert!((new * v - want * v).length() < 1e-18, "axis {i}");
        }
        // A body above both bounds is left alone.
        assert!(matches!(
            link.judge(InertiaPolicy::Repair, 0.5, (0.1, 1e-5)),
            Verdict::Fine
        ));
    }

    #[test]
    fn bound_mass_raises_light_and_massless_bodies() {
        let ic = DMat3::from_diagonal(DVec3::new(1e-3, 1e-3, 1e-3));
        // Massless with a rotational inertia: the relative floor would give 1e-6 of the
        // largest mass (10 kg → 1e-5 kg); the bound 1e-3 kg is above it.
        let massless = body(0.0, DVec3::ZERO, ic, 0.05);
        let (inertia, change) = changed(massless.judge(InertiaPolicy::Repair, 10.0, (1e-3, 0.0)));
        assert_eq!(inertia.mass, 1e-3);
        assert_eq!(change.fixes, vec!["boundmass"]);
        assert!(max_abs(inertia.inertia_about_com() - ic) < 1e-18);
        let (inertia, _) = changed(massless.judge(InertiaPolicy::Repair, 10.0, (0.0, 0.0)));
        assert_eq!(inertia.mass, MASS_FLOOR * 10.0);
        // A light body: its mass raised, its rotational inertia kept.
        let light = body(2e-4, DVec3::new(0.0, 0.0, 0.01), ic, 0.01);
        let (inertia, change) = changed(light.judge(InertiaPolicy::Repair, 10.0, (1e-3, 0.0)));
        assert_eq!(inertia.mass, 1e-3);
        assert_eq!(change.defects[0].kind, InertiaDefectKind::MassBelowBound);
        assert!(
            change.to_string().contains("mass 0.0002 → 0.001 kg"),
            "{change}"
        );
        assert!(max_abs(inertia.inertia_about_com() - ic) < 1e-18);
        assert!((inertia.com() - DVec3::new(0.0, 0.0, 0.01)).length() < 1e-16);
    }

    #[test]
    fn principal_moments_of_tiny_and_zero_matrices() {
        assert_eq!(principal_moments(DMat3::ZERO).0, [0.0; 3]);
        let m = DMat3::from_cols(
            DVec3::new(0.0, 0.0, 2.40741e-35),
            DVec3::ZERO,
            DVec3::new(2.40741e-35, 0.0, 0.0),
        );
        let (l, _) = principal_moments(m);
        assert!((l[0] + 2.40741e-35).abs() < 1e-49 && (l[2] - 2.40741e-35).abs() < 1e-49);
    }
}
