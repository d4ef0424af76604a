//! The rod models along a second parameter `q`: the engine's [`Family`] for the two-parameter
//! continuation of a Hopf, fold or branch point (docs/model.md section 11), each member the rod
//! of the physical model with one [`Field`] set to `q`.

use crate::engine::curve::Family;
use crate::model::Model;
use crate::model::dofs::Layout;
use crate::model::params::{Field, Physical};
use crate::problem::rod::{Parameter, RodProblem, omega_scale};
use crate::{Error, Result};

/// The rod models along a second parameter: `base` with `field` set to `q`, at `base`'s node
/// count (a `per_turn` resolution is fixed at the first value, so that the unknowns stay the
/// same along the curve).
pub struct RodFamily {
    base: Physical,
    field: Field,
    omega_scale: f64,
    /// A helix ratio held at a value while `field` varies (the phase diagram keeps `R/lambda`
    /// while the pitch varies).
    hold: Option<(Field, f64)>,
}

impl RodFamily {
    /// The family of `base` in `field`, followed in `omega` up to `omega_max` (rad/s, for the
    /// scale of `omegabar` in the arclength); `field` must be a number of `base`.
    pub fn new(base: &Physical, field: Field, omega_max: f64) -> Result<Self> {
        if field.get(base).is_none() {
            return Err(Error::input(
                "--vary",
                format!(
                    "`{}` is not a numeric field of the study (or {}, {})",
                    field.key(),
                    Field::LambdaOverL.key(),
                    Field::ROverLambda.key()
                ),
            ));
        }
        let mut base = base.clone();
        base.discretization.per_turn = None;
        let model = Model::new(&base)?;
        Ok(RodFamily {
            omega_scale: omega_scale(model.scales.omega_to_bar(omega_max)),
            base,
            field,
            hold: None,
        })
    }

    /// The family with the helix ratio `ratio` set to `value` after the field in every member.
    pub fn holding(self, ratio: Field, value: f64) -> Self {
        RodFamily {
            hold: Some((ratio, value)),
            ..self
        }
    }

    /// The field that varies.
    pub fn field(&self) -> Field {
        self.field
    }

    /// The physical model at `q`, validated.
    pub fn physical(&self, q: f64) -> Result<Physical> {
        let mut p = self.base.clone();
        self.field.set(&mut p, q)?;
        if let Some((ratio, value)) = self.hold {
            ratio.set(&mut p, value)?;
        }
        p.validate()?;
        Ok(p)
    }

    /// The dimensionless model at `q`.
    pub fn model(&self, q: f64) -> Result<Model> {
        Model::new(&self.physical(q)?)
    }
}

impl Family for RodFamily {
    type Member = RodProblem<Model>;

    fn member(&self, q: f64) -> Result<RodProblem<Model>> {
        let model = self.model(q)?;
        model.check_resolution()?;
        Ok(RodProblem::new(model, Parameter::Omega, self.omega_scale))
    }

    /// Moves every free node with the natural shape (`x + X_to - X_from`), angles unchanged.
    fn carry(&self, u: &[f64], from: &RodProblem<Model>, to: &RodProblem<Model>) -> Vec<f64> {
        let fp = from.model.rod.layout.free_positions();
        let (a, b) = (&from.model.natural, &to.model.natural);
        let mut carried = u.to_vec();
        for (i, c) in carried[..fp].chunks_exact_mut(3).enumerate() {
            let d = b[Layout::CLAMPED_NODES + i] - a[Layout::CLAMPED_NODES + i];
            for k in 0..3 {
                c[k] += d[k];
            }
        }
        carried
    }

    /// `to` measures the angles in `from`'s chart carried onto the edges of `guess`, with its
    /// own clamp frame ([`crate::model::rod::frame::Chart::with_clamp_of`]).
    fn adopt(&self, from: &RodProblem<Model>, to: &RodProblem<Model>, guess: &[f64]) {
        let x = to.steady(0.0).config(guess).x;
        to.set_chart(from.chart().transported(&x).with_clamp_of(&to.model.chart));
    }
}
