//! Physical parameters in SI units, validated once at the boundary, the scales that make them
//! dimensionless, and the typed lens ([`Field`]) through which a second parameter varies one of
//! them.
//!
//! Inside the solver lengths are measured in units of the reference length `ell` (the axial
//! length `l` of a helix, the contour length `L` of an arc or a straight rod), forces in units of
//! `EI / ell^2` and time in units of `mu ell^4 / EI`. So `EI = 1` and `mu = 1` in the solver and
//! `omegabar = omega mu ell^4 / EI`.

use serde::{Deserialize, Serialize};

use crate::model::fluid::{FluidModel, Quadrature};
use crate::{Error, Result};

/// The elastic rod: material and cross-section.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RodParams {
    /// Young's modulus `E` (Pa).
    #[serde(rename = "E")]
    pub youngs_modulus: f64,
    /// Cross-section radius `r0` (m).
    pub r0: f64,
    /// Density of the rod material `rho_r` (kg/m^3).
    pub rho: f64,
    /// Poisson ratio `nu` (the model uses 0.5, an incompressible rubber).
    #[serde(default = "default_poisson")]
    pub nu: f64,
}

fn default_poisson() -> f64 {
    0.5
}

/// The fluid bath and gravity.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FluidParams {
    /// Dynamic viscosity `mu` (Pa s).
    pub mu: f64,
    /// Fluid density `rho_f` (kg/m^3), for buoyancy.
    pub rho: f64,
    /// Gravitational acceleration `g` (m/s^2).
    #[serde(default = "default_gravity")]
    pub g: f64,
    /// Discretization of Lighthill's integral (`reference` or `original`, docs/studies.md).
    #[serde(default)]
    pub quadrature: Quadrature,
    /// Hydrodynamic model: `rpy` (default, docs/model.md section 9) or `lighthill` (the published
    /// operator, section 3). Always written, so that a study read back keeps its model.
    #[serde(default)]
    pub model: FluidModel,
    /// RPY blob radius `a` (m); default `e^(3/2) r0 / 4`. Only with `model = "rpy"`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub blob_radius: Option<f64>,
    /// RPY quadrature points per blob radius, about (default
    /// [`crate::model::fluid::rpy::POINTS_PER_BLOB`] = 8; 2..64): each edge gets the power of two
    /// of two-point Gauss cells nearest to this many points per blob radius, so the points stay
    /// where they are when the spacing is halved. Fewer is cheaper (the kernels cost the square)
    /// and less accurate: the error is second order in the spacing and the same at every `N` of a
    /// halving ladder (`omega_b` of the representative helix 7.7e-5 rad/s above its limit in the
    /// points at 8, 1.9e-5 at 16; docs/model.md section 9). Only with `model = "rpy"`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub points_per_blob: Option<f64>,
}

fn default_gravity() -> f64 {
    9.81
}

/// Handedness of a helix.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Handedness {
    Right,
    Left,
}

impl Handedness {
    /// `h = +1` (right) or `-1` (left), as in `X(phi) = (R cos phi, -h R sin phi, -lambda phi / 2 pi)`.
    pub(crate) fn sign(self) -> f64 {
        match self {
            Handedness::Right => 1.0,
            Handedness::Left => -1.0,
        }
    }
}

/// How a helix is clamped to the motor (docs/model.md section 8).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum HelixClamp {
    /// The reference: clamped at the helix's own end, the clamped tangent the helix's.
    #[default]
    Helix,
    /// As lab rods on a motor shaft: the first edge on the rotation axis (pointing down), joined
    /// to the helix's end by a straight radial connector.
    Axis,
}

/// The stress-free (natural) shape of the rod.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case", deny_unknown_fields)]
pub enum ShapeParams {
    /// Helix about the rotation axis, clamped at its top end.
    Helix {
        /// Axial length `l` (m).
        l: f64,
        /// Pitch `lambda` (m).
        lambda: f64,
        /// Helix radius `R` (m).
        #[serde(rename = "R")]
        radius: f64,
        handedness: Handedness,
        /// Where the rod is held (default: the helix's own end, tangent along the helix).
        #[serde(default)]
        clamp: HelixClamp,
    },
    /// Planar circular arc, tangent at the clamp along `-e_z`.
    Arc {
        /// Contour length `L` (m).
        #[serde(rename = "L")]
        length: f64,
        /// Radius of curvature `R` (m).
        #[serde(rename = "R")]
        radius: f64,
    },
    /// Straight rod whose clamped tangent makes the angle `alpha` with `-e_z`.
    Straight {
        /// Contour length `L` (m).
        #[serde(rename = "L")]
        length: f64,
        /// Clamp angle `alpha` (degrees) from the downward vertical, in `[0, 180]`.
        alpha_deg: f64,
    },
}

impl ShapeParams {
    /// The reference length `ell`: `l` for a helix, `L` for an arc or a straight rod.
    pub fn reference_length(&self) -> f64 {
        match *self {
            ShapeParams::Helix { l, .. } => l,
            ShapeParams::Arc { length, .. } | ShapeParams::Straight { length, .. } => length,
        }
    }

    /// Contour length of the continuous natural shape (m).
    pub fn contour_length(&self) -> f64 {
        match *self {
            ShapeParams::Helix {
                l,
                lambda,
                radius,
                clamp,
                ..
            } => {
                let helix = (l / lambda)
                    * (lambda * lambda + (2.0 * std::f64::consts::PI * radius).powi(2)).sqrt();
                match clamp {
                    HelixClamp::Helix => helix,
                    // The connector; the short edge on the axis is left out.
                    HelixClamp::Axis => helix + radius,
                }
            }
            ShapeParams::Arc { length, .. } | ShapeParams::Straight { length, .. } => length,
        }
    }
}

/// Spatial resolution.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Discretization {
    /// Number of nodes `N` (at least 5).
    pub nodes: usize,
    /// For a helix: nodes per turn instead of a fixed count, `N = round(per_turn * turns) + 1`,
    /// capped two below the admissible maximum if the fluid model has one (the resolution then follows the geometry in a
    /// sweep). Resolved into `nodes` when the study is loaded.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub per_turn: Option<f64>,
    /// Where the clamped first edge lies (docs/model.md section 2): `"first"` (from the clamp
    /// point down, the published discretization) or `"centred"` (centred on the clamp point:
    /// the error of `fluid.model = "rpy"` is then of second order alone). Unset, it follows the
    /// fluid model ([`Physical::clamp_edge`]): `"centred"` with `"rpy"` (`"first"` for a helix
    /// with `shape.clamp = "axis"`), `"first"` with `"lighthill"`. `"centred"` is refused with
    /// `"lighthill"` and with the axis clamp.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub clamp_edge: Option<ClampEdge>,
}

/// How the clamp is imposed on the polygon (docs/model.md section 2). Either way `x_0`, `x_1`
/// and `theta^0` are held: the clamped edge fixes the tangent at its midpoint.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum ClampEdge {
    /// The reference: node 0 at the clamp point, the clamped edge the rod's first `h`. The
    /// tangent is then held at `s = h/2`: the discrete rod is clamped half an edge below the
    /// clamp, a first-order error in the spacing (the sag at rest converges at observed order
    /// 1.76 .. 1.34 from N = 60 to 1889 on the representative helix). The default with
    /// `fluid.model = "lighthill"`.
    First,
    /// The clamped edge centred on the clamp point: nodes at `s_i = (i - 1/2) h`,
    /// `h = L/(N - 3/2)`, so the tangent is held at `s = 0` and node 1 at `s = h/2`; the half edge
    /// above the clamp is no part of the rod for the fluid, which sees the clamp point
    /// `(x_0 + x_1)/2` as its first node (the sag converges at order 2.00). Only with
    /// `fluid.model = "rpy"`, whose default it is.
    Centred,
}

impl ClampEdge {
    /// The value's name in a study file.
    pub fn name(self) -> &'static str {
        match self {
            ClampEdge::First => "first",
            ClampEdge::Centred => "centred",
        }
    }

    /// The clamp point of a configuration: node 0, or the midpoint of the clamped edge.
    pub fn clamp_point(self, x: &[nalgebra::Vector3<f64>]) -> nalgebra::Vector3<f64> {
        match self {
            ClampEdge::First => x[0],
            ClampEdge::Centred => 0.5 * (x[0] + x[1]),
        }
    }
}

/// Everything that defines the physical problem, in SI units.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Physical {
    pub rod: RodParams,
    pub fluid: FluidParams,
    pub shape: ShapeParams,
    pub discretization: Discretization,
}

fn positive(field: &str, value: f64) -> Result<()> {
    if !value.is_finite() {
        return Err(Error::input(
            field,
            format!("must be a finite number, got {value}"),
        ));
    }
    if value <= 0.0 {
        return Err(Error::input(field, format!("must be > 0, got {value}")));
    }
    Ok(())
}

fn non_negative(field: &str, value: f64) -> Result<()> {
    if !value.is_finite() || value < 0.0 {
        return Err(Error::input(
            field,
            format!("must be a finite number >= 0, got {value}"),
        ));
    }
    Ok(())
}

impl Physical {
    /// The representative helix of docs/model.md section 7 (a macroscopic flagellum in glycerin),
    /// right-handed: with `omega > 0` (counter-clockwise seen from above) its propulsive force is
    /// positive (the left-handed helix pushes the other way and buckles early). The fluid is the
    /// RPY line (the default model).
    pub fn representative() -> Self {
        Physical {
            rod: RodParams {
                youngs_modulus: 1255e3,
                r0: 1.58e-3,
                rho: 1273.0,
                nu: 0.5,
            },
            fluid: FluidParams {
                mu: 1.6,
                rho: 1240.0,
                g: 9.81,
                quadrature: Quadrature::Reference,
                model: FluidModel::Rpy,
                blob_radius: None,
                points_per_blob: None,
            },
            shape: ShapeParams::Helix {
                l: 0.20,
                lambda: 0.05,
                radius: 0.0159,
                handedness: Handedness::Right,
                clamp: HelixClamp::Helix,
            },
            discretization: Discretization {
                nodes: 60,
                per_turn: None,
                clamp_edge: None,
            },
        }
    }

    /// The representative helix with Lighthill's operator as published (section 3), at the
    /// published resolution `N = 60`: the model of the paper, for comparison with it.
    pub fn representative_lighthill() -> Self {
        let mut p = Self::representative();
        p.fluid.model = FluidModel::Lighthill;
        p
    }

    /// Where the clamped edge lies (docs/model.md section 2): `discretization.clamp_edge` if
    /// given, else the fluid model's default: [`ClampEdge::Centred`] on the RPY line (its error
    /// is then of second order alone, section 10), except for a helix held on its axis, and
    /// [`ClampEdge::First`] on Lighthill's (the published model).
    pub fn clamp_edge(&self) -> ClampEdge {
        self.discretization.clamp_edge.unwrap_or(
            if self.fluid.model == FluidModel::Rpy && !self.axis_clamped() {
                ClampEdge::Centred
            } else {
                ClampEdge::First
            },
        )
    }

    /// A helix held on its axis (`shape.clamp = "axis"`).
    fn axis_clamped(&self) -> bool {
        matches!(
            self.shape,
            ShapeParams::Helix {
                clamp: HelixClamp::Axis,
                ..
            }
        )
    }

    /// Checks every field against its allowed range; the error names the field.
    pub fn validate(&self) -> Result<()> {
        let rod = &self.rod;
        positive("rod.E", rod.youngs_modulus)?;
        positive("rod.r0", rod.r0)?;
        non_negative("rod.rho", rod.rho)?;
        if !rod.nu.is_finite() || rod.nu <= -1.0 || rod.nu > 0.5 {
            return Err(Error::input(
                "rod.nu",
                format!("must lie in (-1, 0.5], got {}", rod.nu),
            ));
        }
        positive("fluid.mu", self.fluid.mu)?;
        non_negative("fluid.rho", self.fluid.rho)?;
        non_negative("fluid.g", self.fluid.g)?;
        match self.shape {
            ShapeParams::Helix {
                l, lambda, radius, ..
            } => {
                positive("shape.l", l)?;
                positive("shape.lambda", lambda)?;
                positive("shape.R", radius)?;
                if rod.r0 >= radius {
                    return Err(Error::input(
                        "rod.r0",
                        format!(
                            "must be smaller than the helix radius shape.R = {radius}, got {}",
                            rod.r0
                        ),
                    ));
                }
                if lambda <= 2.0 * rod.r0 {
                    return Err(Error::input(
                        "shape.lambda",
                        format!(
                            "must exceed 2 r0 = {} (otherwise neighbouring turns touch), got {lambda}",
                            2.0 * rod.r0
                        ),
                    ));
                }
                if l < lambda / 4.0 {
                    return Err(Error::input(
                        "shape.l",
                        format!(
                            "must be at least a quarter pitch (lambda/4 = {}), got {l}",
                            lambda / 4.0
                        ),
                    ));
                }
            }
            ShapeParams::Arc { length, radius } => {
                positive("shape.L", length)?;
                positive("shape.R", radius)?;
                if rod.r0 >= radius {
                    return Err(Error::input(
                        "rod.r0",
                        format!(
                            "must be smaller than the arc radius shape.R = {radius}, got {}",
                            rod.r0
                        ),
                    ));
                }
                let max = 2.0 * std::f64::consts::PI * radius;
                if length >= max {
                    return Err(Error::input(
                        "shape.L",
                        format!(
                            "must be below one full circle 2 pi R = {max} (the arc would close), got {length}"
                        ),
                    ));
                }
            }
            ShapeParams::Straight { length, alpha_deg } => {
                positive("shape.L", length)?;
                if !alpha_deg.is_finite() || !(0.0..=180.0).contains(&alpha_deg) {
                    return Err(Error::input(
                        "shape.alpha_deg",
                        format!("must lie in [0, 180] degrees, got {alpha_deg}"),
                    ));
                }
            }
        }
        let ell = self.shape.contour_length();
        if rod.r0 >= 0.5 * ell {
            return Err(Error::input(
                "rod.r0",
                format!(
                    "must be far below the contour length {ell} m (a slender rod), got {}",
                    rod.r0
                ),
            ));
        }
        if self.discretization.nodes < 5 {
            return Err(Error::input(
                "discretization.nodes",
                format!("must be at least 5, got {}", self.discretization.nodes),
            ));
        }
        if self.discretization.nodes > 5000 {
            return Err(Error::input(
                "discretization.nodes",
                format!(
                    "must be at most 5000 (dense algebra), got {}",
                    self.discretization.nodes
                ),
            ));
        }
        if self.discretization.clamp_edge == Some(ClampEdge::Centred) {
            let refused = if self.fluid.model != FluidModel::Rpy {
                Some("fluid.model = \"lighthill\"")
            } else if self.axis_clamped() {
                Some("shape.clamp = \"axis\"")
            } else {
                None
            };
            if let Some(with) = refused {
                return Err(Error::input(
                    "discretization.clamp_edge",
                    format!(
                        "\"centred\" is not supported with {with}: allowed there is \"first\" \
                         (\"centred\" needs fluid.model = \"rpy\" and a rod held at its own end)"
                    ),
                ));
            }
        }
        self.validate_fluid_model()
    }

    fn validate_fluid_model(&self) -> Result<()> {
        let fluid = &self.fluid;
        match fluid.model {
            FluidModel::Lighthill => {
                if let Some(a) = fluid.blob_radius {
                    return Err(Error::input(
                        "fluid.blob_radius",
                        format!(
                            "applies to fluid.model = \"rpy\" only, got {a} with \"lighthill\""
                        ),
                    ));
                }
                if let Some(q) = fluid.points_per_blob {
                    return Err(Error::input(
                        "fluid.points_per_blob",
                        format!(
                            "applies to fluid.model = \"rpy\" only, got {q} with \"lighthill\""
                        ),
                    ));
                }
            }
            FluidModel::Rpy => {
                if let Some(a) = fluid.blob_radius {
                    let max = 0.5 * self.shape.contour_length();
                    if !(a.is_finite() && a > 0.0 && a < max) {
                        return Err(Error::input(
                            "fluid.blob_radius",
                            format!(
                                "must be a finite length in (0, {max}) m (half the contour length), got {a}"
                            ),
                        ));
                    }
                }
                let allowed = crate::model::fluid::rpy::POINTS_PER_BLOB_RANGE;
                if let Some(q) = fluid.points_per_blob
                    && !allowed.contains(&q)
                {
                    return Err(Error::input(
                        "fluid.points_per_blob",
                        format!(
                            "must lie in [{}, {}], got {q}",
                            allowed.start(),
                            allowed.end()
                        ),
                    ));
                }
                if fluid.quadrature != Quadrature::Reference {
                    return Err(Error::input(
                        "fluid.quadrature",
                        "selects a Lighthill quadrature; with fluid.model = \"rpy\" it must stay \"reference\"",
                    ));
                }
            }
        }
        Ok(())
    }

    /// Bending stiffness `EI = E pi r0^4 / 4` (N m^2).
    pub fn bending_stiffness(&self) -> f64 {
        self.rod.youngs_modulus * std::f64::consts::PI * self.rod.r0.powi(4) / 4.0
    }

    /// Twisting stiffness `GJ = G pi r0^4 / 2`, `G = E / (2 (1 + nu))` (N m^2).
    pub fn twisting_stiffness(&self) -> f64 {
        let shear = self.rod.youngs_modulus / (2.0 * (1.0 + self.rod.nu));
        shear * std::f64::consts::PI * self.rod.r0.powi(4) / 2.0
    }

    /// Stretching stiffness `EA = E pi r0^2` (N).
    pub(crate) fn stretching_stiffness(&self) -> f64 {
        self.rod.youngs_modulus * std::f64::consts::PI * self.rod.r0.powi(2)
    }

    /// Net weight per unit length, buoyancy included: `q = (rho_r - rho_f) g pi r0^2` (N/m).
    pub fn weight_per_length(&self) -> f64 {
        (self.rod.rho - self.fluid.rho) * self.fluid.g * std::f64::consts::PI * self.rod.r0.powi(2)
    }

    /// The unit system of the solver.
    pub fn scales(&self) -> Scales {
        let ell = self.shape.reference_length();
        let ei = self.bending_stiffness();
        Scales {
            length: ell,
            force: ei / (ell * ell),
            time: self.fluid.mu * ell.powi(4) / ei,
        }
    }
}

/// Units of the dimensionless solver: lengths by `ell`, forces by `EI/ell^2`, time by
/// `mu ell^4 / EI`.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct Scales {
    /// `ell` (m).
    pub length: f64,
    /// `EI / ell^2` (N).
    pub force: f64,
    /// `mu ell^4 / EI` (s).
    pub time: f64,
}

impl Scales {
    /// `omegabar = omega * time`.
    pub fn omega_to_bar(&self, omega: f64) -> f64 {
        omega * self.time
    }
    /// `omega = omegabar / time` (rad/s).
    pub fn omega_from_bar(&self, omegabar: f64) -> f64 {
        omegabar / self.time
    }
    /// Torque unit `EI / ell` (N m).
    pub(crate) fn torque(&self) -> f64 {
        self.force * self.length
    }
}

/// A number of the physical model that a second parameter varies (the stability boundary as a
/// curve in it): a typed lens on [`Physical`], named by its study key. The helix ratios set one
/// length from another: `shape.lambda_over_l` sets the pitch to the value times `l` (`l` and `R`
/// fixed), `shape.R_over_lambda` the radius to the value times the pitch.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Field {
    YoungsModulus,
    RodRadius,
    RodDensity,
    Poisson,
    Viscosity,
    FluidDensity,
    Gravity,
    BlobRadius,
    PointsPerBlob,
    /// `shape.l` of a helix.
    AxialLength,
    /// `shape.L` of an arc or a straight rod.
    ContourLength,
    Pitch,
    Radius,
    Tilt,
    LambdaOverL,
    ROverLambda,
}

impl Field {
    /// Every field, in the order of the study file.
    const ALL: [Field; 16] = [
        Field::YoungsModulus,
        Field::RodRadius,
        Field::RodDensity,
        Field::Poisson,
        Field::Viscosity,
        Field::FluidDensity,
        Field::Gravity,
        Field::BlobRadius,
        Field::PointsPerBlob,
        Field::AxialLength,
        Field::ContourLength,
        Field::Pitch,
        Field::Radius,
        Field::Tilt,
        Field::LambdaOverL,
        Field::ROverLambda,
    ];

    /// The study key (`rod.E`, `shape.R_over_lambda`, ...).
    pub fn key(self) -> &'static str {
        match self {
            Field::YoungsModulus => "rod.E",
            Field::RodRadius => "rod.r0",
            Field::RodDensity => "rod.rho",
            Field::Poisson => "rod.nu",
            Field::Viscosity => "fluid.mu",
            Field::FluidDensity => "fluid.rho",
            Field::Gravity => "fluid.g",
            Field::BlobRadius => "fluid.blob_radius",
            Field::PointsPerBlob => "fluid.points_per_blob",
            Field::AxialLength => "shape.l",
            Field::ContourLength => "shape.L",
            Field::Pitch => "shape.lambda",
            Field::Radius => "shape.R",
            Field::Tilt => "shape.alpha_deg",
            Field::LambdaOverL => "shape.lambda_over_l",
            Field::ROverLambda => "shape.R_over_lambda",
        }
    }

    /// The field of a study key, if it is one.
    pub(crate) fn of_key(key: &str) -> Option<Field> {
        Field::ALL.into_iter().find(|f| f.key() == key)
    }

    /// The value in `p`, or `None` where the model has no such number (a helix length of an
    /// arc, an RPY setting left at its default).
    pub fn get(self, p: &Physical) -> Option<f64> {
        let helix = match p.shape {
            ShapeParams::Helix {
                l, lambda, radius, ..
            } => Some((l, lambda, radius)),
            _ => None,
        };
        match (self, &p.shape) {
            (Field::YoungsModulus, _) => Some(p.rod.youngs_modulus),
            (Field::RodRadius, _) => Some(p.rod.r0),
            (Field::RodDensity, _) => Some(p.rod.rho),
            (Field::Poisson, _) => Some(p.rod.nu),
            (Field::Viscosity, _) => Some(p.fluid.mu),
            (Field::FluidDensity, _) => Some(p.fluid.rho),
            (Field::Gravity, _) => Some(p.fluid.g),
            (Field::BlobRadius, _) => p.fluid.blob_radius,
            (Field::PointsPerBlob, _) => p.fluid.points_per_blob,
            (Field::AxialLength, _) => helix.map(|h| h.0),
            (
                Field::ContourLength,
                ShapeParams::Arc { length, .. } | ShapeParams::Straight { length, .. },
            ) => Some(*length),
            (Field::Pitch, _) => helix.map(|h| h.1),
            (
                Field::Radius,
                ShapeParams::Helix { radius, .. } | ShapeParams::Arc { radius, .. },
            ) => Some(*radius),
            (Field::Tilt, ShapeParams::Straight { alpha_deg, .. }) => Some(*alpha_deg),
            (Field::LambdaOverL, _) => helix.map(|(l, lambda, _)| lambda / l),
            (Field::ROverLambda, _) => helix.map(|(_, lambda, r)| r / lambda),
            _ => None,
        }
    }

    /// `p` with this field set to `value` (not validated: see [`Physical::validate`]); an input
    /// error naming the key where the model has no such number.
    pub fn set(self, p: &mut Physical, value: f64) -> Result<()> {
        let missing = || {
            Error::input(
                self.key(),
                match self {
                    Field::LambdaOverL | Field::ROverLambda => "needs a helix".to_string(),
                    _ => "is not a number of this shape".to_string(),
                },
            )
        };
        let target: &mut f64 = match (self, &mut p.shape) {
            (Field::YoungsModulus, _) => &mut p.rod.youngs_modulus,
            (Field::RodRadius, _) => &mut p.rod.r0,
            (Field::RodDensity, _) => &mut p.rod.rho,
            (Field::Poisson, _) => &mut p.rod.nu,
            (Field::Viscosity, _) => &mut p.fluid.mu,
            (Field::FluidDensity, _) => &mut p.fluid.rho,
            (Field::Gravity, _) => &mut p.fluid.g,
            (Field::BlobRadius, _) => p.fluid.blob_radius.insert(value),
            (Field::PointsPerBlob, _) => p.fluid.points_per_blob.insert(value),
            (Field::AxialLength, ShapeParams::Helix { l, .. }) => l,
            (
                Field::ContourLength,
                ShapeParams::Arc { length, .. } | ShapeParams::Straight { length, .. },
            ) => length,
            (Field::Pitch, ShapeParams::Helix { lambda, .. }) => lambda,
            (
                Field::Radius,
                ShapeParams::Helix { radius, .. } | ShapeParams::Arc { radius, .. },
            ) => radius,
            (Field::Tilt, ShapeParams::Straight { alpha_deg, .. }) => alpha_deg,
            (Field::LambdaOverL, ShapeParams::Helix { l, lambda, .. }) => {
                *lambda = value * *l;
                return Ok(());
            }
            (Field::ROverLambda, ShapeParams::Helix { lambda, radius, .. }) => {
                *radius = value * *lambda;
                return Ok(());
            }
            _ => return Err(missing()),
        };
        *target = value;
        Ok(())
    }
}
