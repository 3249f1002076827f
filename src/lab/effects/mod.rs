//! The lab's side of each physical effect, one file each beside `physics/effects/`: when the
//! balance of forces can represent it, the columns it adds, the grid of its nonlinear parameters,
//! how it shapes the command, what it does to the drive, and the signature the diagnosis looks
//! for in a residual. The
//! regression ([`super::regress`]) and the diagnosis ([`super::diagnose`]) run over these
//! descriptions.
//!
//! To give a new effect its lab side: write `effects/<name>.rs` (the name of its physics file)
//! with a unit struct named like its physics type, implementing [`LabEffect`]. The modules and
//! [`REGISTRY`] are made from the physics' catalogue (`physics::effects::catalogue!`), so the
//! lab names no effect here; each side's [`LabEffect::place`] is the order of its columns and of
//! its nonlinear parameters in a fit. An effect that changes the drive needs no place in
//! `regress.rs` or `regress_gear.rs` either: its hooks give the drive's factor from the supply
//! ([`LabEffect::supply_factor`]), its gain per direction or by position
//! ([`LabEffect::direction_gain`], [`LabEffect::position_gain`]), the columns it adds to the
//! drive force of the one-body families ([`LabEffect::drive_gain_terms`],
//! [`LabEffect::drive_force_terms`]) and what it changes in `motor_gear`'s gear
//! ([`LabEffect::gear`]); the regression composes them over the effects of the model.

use super::data::Dataset;
use super::params::Handle;
use super::regress::{IdFit, Term};
use super::signals::Prepared;
use crate::physics::{EffectKind, Family, PlantSpec};

/// One module per effect of the catalogue, and every lab side in catalogue order.
macro_rules! lab_sides {
    ($( $variant:ident => $file:ident : $ty:ty ),* $(,)?) => {
        $( pub mod $file; )*

        /// Every effect's lab side, in the catalogue's order.
        const CATALOGUE: &[&dyn LabEffect] = &[ $( &$file::$variant ),* ];
    };
}
crate::physics::effects::catalogue!(lab_sides);

/// A model and the data it is fitted on, as an effect's lab side sees them.
#[derive(Clone, Copy)]
pub struct Cx<'a> {
    /// The model (with the effect).
    pub spec: &'a PlantSpec,
    /// The raw data set.
    pub raw: &'a Dataset,
    /// Its filtered signals.
    pub d: &'a Prepared,
}

/// A grid of values for one nonlinear parameter (qualified name, values), searched with the
/// linear parameters refitted at each point.
pub type Grid = (String, Vec<f64>);

/// Factor of the drive at the supply ratio `r = S / S_nom` for a command of sign `positive` (see
/// [`LabEffect::supply_factor`]).
pub type SupplyFactor = Box<dyn Fn(f64, bool) -> f64>;

/// A gain of the drive per direction of motion: held on positive motion, where it is part of the
/// balance's scale reference, fitted on negative motion.
#[derive(Debug, Clone)]
pub struct DirectionGain {
    /// Gain on positive motion (held).
    pub pos: f64,
    /// Gain on negative motion: the parameter its column fits.
    pub neg: Handle,
}

/// A gain of the drive that varies with the position.
pub struct PositionGain {
    /// The part held in the drive's reference column; the effect's own columns
    /// ([`LabEffect::drive_gain_terms`]) carry the rest.
    pub held: f64,
    /// The whole gain at a position.
    pub at: Box<dyn Fn(f64) -> f64>,
}

/// The drive force of a one-body family as the effects' columns on it see it:
/// `F(k) = K D(k) K±(k) G(y_k)`.
pub struct DriveForce<'a> {
    /// `K`, the drive's gain (force per unit of the drive signal).
    pub gain: f64,
    /// `D`, the drive signal after the power stage (held, moved to the acceleration's instant),
    /// filtered like every column.
    pub signal: &'a [f64],
    /// The same signal before the filter.
    pub unfiltered: &'a [f64],
    /// `K±`, the gain of the direction of motion at each sample (1 without a direction gain).
    pub direction: &'a [f64],
    /// `G`, the gain by position, when an effect makes one.
    pub position: Option<&'a PositionGain>,
}

impl DriveForce<'_> {
    /// The whole drive force at sample `k` before the filter, at the measured position `y`:
    /// `F = K D K± G(y)`.
    pub fn whole(&self, k: usize, y: f64) -> f64 {
        self.gain
            * self.unfiltered[k]
            * self.direction[k]
            * self.position.map_or(1.0, |g| (g.at)(y))
    }
}

/// `motor_gear`'s gear as its drive side runs it: the ratio and the contact between gear and
/// load, rigid and constant unless an effect changes them ([`LabEffect::gear`]).
pub struct Gear {
    /// `h_0`, the nominal ratio.
    pub nominal_ratio: f64,
    /// `K_g`, the contact's stiffness (N·m/rad).
    pub stiffness: f64,
    /// `C_g`, the contact's damping (N·m·s/rad).
    pub damping: f64,
    /// The ratio `h` and its rate `ḣ` at load angle `θ_l` and speed `ω_l`.
    pub ratio: Box<dyn Fn(f64, f64) -> (f64, f64)>,
    /// The torque from gear to load at twist `Δ = θ_g - θ_l` and its rate.
    pub contact: Box<dyn Fn(f64, f64) -> f64>,
}

impl Gear {
    /// A gear of constant ratio `h_0` with a rigid contact.
    pub fn rigid(nominal_ratio: f64, stiffness: f64, damping: f64) -> Gear {
        Gear {
            nominal_ratio,
            stiffness,
            damping,
            ratio: Box::new(move |_, _| (nominal_ratio, 0.0)),
            // τ_c = K_g Δ + C_g Δ' (Bao et al. eq. 1, no play)
            contact: Box::new(move |twist, rate| stiffness * twist + damping * rate),
        }
    }
}

/// The levels that hold a body at rest (stiction): the breakaway force in each direction.
#[derive(Debug, Clone)]
pub struct Breakaway {
    /// Positive direction.
    pub pos: Handle,
    /// Negative direction.
    pub neg: Handle,
}

/// What the lab knows of one effect.
pub trait LabEffect: Sync {
    /// The effect.
    fn kind(&self) -> EffectKind;

    /// Its place among the lab sides (lowest first): the order of its columns in the balance
    /// and of its nonlinear parameters in a fit. Unique (a test checks it); the places of the
    /// effects known so far step by 10 to leave room between them.
    fn place(&self) -> u16;

    /// True when the balance of forces of a `family` model can represent the effect with the
    /// signals `d` recorded (with a measured current, what acts before the coil is invisible).
    fn representable(&self, _family: Family, _d: &Prepared) -> bool {
        true
    }

    /// Grids of its nonlinear parameters, searched one after the other; none for an effect
    /// linear in its parameters.
    fn grid(&self, _cx: &Cx) -> anyhow::Result<Vec<Grid>> {
        Ok(Vec::new())
    }

    /// Its nonlinear parameters and their values, as the balance holds them.
    fn nonlinear(&self, _cx: &Cx) -> anyhow::Result<Vec<(String, f64)>> {
        Ok(Vec::new())
    }

    /// Set a grid point of one of its nonlinear parameters (an effect may tie others to it).
    fn set_grid_value(&self, spec: &mut PlantSpec, name: &str, value: f64) -> anyhow::Result<()> {
        spec.set(name, value)?;
        Ok(())
    }

    /// Starting values before the grid search, from the data.
    fn start(&self, _spec: &mut PlantSpec, _raw: &Dataset) -> anyhow::Result<()> {
        Ok(())
    }

    /// Its place in the power stage (lowest first) and what it does to the command there.
    fn command_stage(&self) -> Option<u8> {
        None
    }

    /// Shape the command `u` (sample period `dt`) in its place in the power stage.
    fn shape_command(&self, _spec: &PlantSpec, _u: &mut Vec<f64>, _dt: f64) -> anyhow::Result<()> {
        Ok(())
    }

    /// Factor of the dry friction levels per sample (`None`: 1).
    fn dry_scale(&self, _cx: &Cx) -> anyhow::Result<Option<Vec<f64>>> {
        Ok(None)
    }

    /// Its terms among the resisting forces on the moving body (the load of `motor_gear`); dry
    /// friction columns carry the factor `dry_scale` per sample.
    fn load_terms(
        &self,
        _cx: &Cx,
        _dry_scale: Option<&[f64]>,
        _terms: &mut Vec<Term>,
    ) -> anyhow::Result<()> {
        Ok(())
    }

    /// Factor of the drive at the supply ratio `r = S / S_nom`, when the power stage is computed
    /// for the nominal supply and the drive follows the actual one; `None`: the supply only
    /// limits the drive.
    fn supply_factor(&self, _spec: &PlantSpec) -> anyhow::Result<Option<SupplyFactor>> {
        Ok(None)
    }

    /// The drive's gain per direction of motion, when the effect makes one.
    fn direction_gain(&self, _spec: &PlantSpec) -> anyhow::Result<Option<DirectionGain>> {
        Ok(None)
    }

    /// The drive's gain by position, when the effect makes one.
    fn position_gain(&self, _spec: &PlantSpec) -> anyhow::Result<Option<PositionGain>> {
        Ok(None)
    }

    /// Its columns on the filtered drive force of a one-body family, linear in its parameters
    /// (after the drive's reference column).
    fn drive_gain_terms(
        &self,
        _cx: &Cx,
        _drive: &DriveForce,
        _terms: &mut Vec<Term>,
    ) -> anyhow::Result<()> {
        Ok(())
    }

    /// Its columns built on the whole drive force before the filter (after every effect's
    /// [`LabEffect::drive_gain_terms`]).
    fn drive_force_terms(
        &self,
        _cx: &Cx,
        _drive: &DriveForce,
        _terms: &mut Vec<Term>,
    ) -> anyhow::Result<()> {
        Ok(())
    }

    /// What it changes in `motor_gear`'s gear.
    fn gear(&self, _spec: &PlantSpec, _gear: &mut Gear) -> anyhow::Result<()> {
        Ok(())
    }

    /// True when one of its columns is proportional to the speed, as the pneumatic chamber's
    /// compliance `(m/τ) v` is: the two cannot both be fitted with the compliance as the scale.
    fn spans_speed(&self) -> bool {
        false
    }

    /// True when a value of its grid parameter below the best point's, that the record cannot
    /// tell from the best, is kept (a parameter the record may not resolve, whose larger values
    /// win by chance).
    fn prefers_smallest(&self) -> bool {
        false
    }

    /// The levels that hold the body at rest, when the effect is one that does.
    fn breakaway(&self, _spec: &PlantSpec) -> anyhow::Result<Option<Breakaway>> {
        Ok(None)
    }

    /// Effects whose force this one reproduces at some of its parameters' values (a spring's
    /// pretension is an offset; a Stribeck curve with an endless Stribeck velocity is Coulomb
    /// friction): fitting as well as one of those, it is that one with parameters to spare,
    /// not a rival the record cannot tell from it.
    fn reproduces(&self) -> &'static [EffectKind] {
        &[]
    }

    /// What its force follows, and the record that shows it apart from effects that follow
    /// something else: where a record moves the two together, the diagnosis cannot tell them
    /// apart and says which record would ([`crate::lab::undecided`]).
    fn separated_by(&self) -> Separation;

    /// The effect's signature in the residual of a model without it.
    fn evidence(&self, ev: &Evidence) -> String;
}

/// What an effect's force follows and the record that shows it (see
/// [`LabEffect::separated_by`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Separation {
    /// The signal its force follows, e.g. "the direction of motion".
    pub follows: &'static str,
    /// The excitation that moves that signal apart from the others, e.g. "motion that goes on
    /// while the command reverses".
    pub shown_by: &'static str,
}

/// Every effect's lab side, in the order of their places: the order of their columns in the
/// balance and of their nonlinear parameters in a fit.
pub static REGISTRY: std::sync::LazyLock<Vec<&'static dyn LabEffect>> =
    std::sync::LazyLock::new(|| {
        let mut sides = CATALOGUE.to_vec();
        sides.sort_by_key(|e| e.place());
        sides
    });

/// The lab's side of `kind`. Every effect has one (a test checks it).
pub fn of(kind: EffectKind) -> anyhow::Result<&'static dyn LabEffect> {
    REGISTRY
        .iter()
        .copied()
        .find(|e| e.kind() == kind)
        .ok_or_else(|| anyhow::anyhow!("effect '{kind}' has no lab side in lab/effects"))
}

/// The lab sides of the effects of `spec`, in registry order.
pub fn present(spec: &PlantSpec) -> impl Iterator<Item = &'static dyn LabEffect> + '_ {
    REGISTRY
        .iter()
        .copied()
        .filter(|e| spec.effects.iter().any(|s| s.kind == e.kind()))
}

/// True when what acts on the command before the coil or armature shows in the data: not on a
/// solenoid or a motor whose current is recorded (the balance is driven by that current).
pub fn command_visible(family: Family, d: &Prepared) -> bool {
    !(matches!(family, Family::Solenoid | Family::MotorGear) && d.current.is_some())
}

/// Geometric grid of `n` values from `lo` to `hi`.
pub fn geometric(lo: f64, hi: f64, n: usize) -> Vec<f64> {
    (0..n)
        .map(|i| lo * (hi / lo).powf(i as f64 / (n - 1) as f64))
        .collect()
}

/// What the diagnosis shows an effect: the residual of the model without it and the data.
pub struct Evidence<'a> {
    /// The family of the model.
    pub family: Family,
    /// The fit of the model without the effect.
    pub base: &'a IdFit,
    /// The raw data set.
    pub data: &'a Dataset,
    /// Its filtered signals.
    pub d: &'a Prepared,
    /// Unit of the residual (N or N·m).
    pub unit: &'a str,
}

impl Evidence<'_> {
    /// The moving residual.
    pub fn r(&self) -> &[f64] {
        &self.base.residual
    }

    /// Sample index of each residual.
    pub fn idx(&self) -> &[usize] {
        &self.base.index
    }

    /// RMS of the moving residual.
    pub fn sd(&self) -> f64 {
        let r = self.r();
        (r.iter().map(|x| x * x).sum::<f64>() / r.len().max(1) as f64).sqrt()
    }

    /// A signal on the residual's samples.
    pub fn at(&self, f: &dyn Fn(usize) -> f64) -> Vec<f64> {
        self.idx().iter().map(|&k| f(k)).collect()
    }

    /// The drive signal: the current when recorded, else the command (filtered).
    pub fn drive(&self) -> &[f64] {
        self.d.current.as_ref().unwrap_or(&self.d.u)
    }
}

/// Pearson correlation of two series (0 when either is constant).
pub fn corr(a: &[f64], b: &[f64]) -> f64 {
    let n = a.len().min(b.len()).max(1) as f64;
    let ma = a.iter().sum::<f64>() / n;
    let mb = b.iter().sum::<f64>() / n;
    let (mut sab, mut saa, mut sbb) = (0.0, 0.0, 0.0);
    for (x, y) in a.iter().zip(b) {
        sab += (x - ma) * (y - mb);
        saa += (x - ma) * (x - ma);
        sbb += (y - mb) * (y - mb);
    }
    if saa > 0.0 && sbb > 0.0 {
        sab / (saa * sbb).sqrt()
    } else {
        0.0
    }
}

/// Mean of the residuals `r` (indexed like `idx`) at the samples `sel` picks, and their count.
pub fn mean_where(r: &[f64], idx: &[usize], sel: impl Fn(usize) -> bool) -> (f64, usize) {
    let mut s = 0.0;
    let mut n = 0;
    for (i, &k) in idx.iter().enumerate() {
        if sel(k) {
            s += r[i];
            n += 1;
        }
    }
    (if n > 0 { s / n as f64 } else { 0.0 }, n)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_effect_has_one_lab_side() {
        for &kind in EffectKind::ALL {
            let n = REGISTRY.iter().filter(|e| e.kind() == kind).count();
            assert_eq!(n, 1, "{kind}: {n} lab sides");
        }
        assert_eq!(REGISTRY.len(), EffectKind::ALL.len());
    }

    #[test]
    fn every_lab_side_has_a_place_of_its_own() {
        let mut places: Vec<u16> = REGISTRY.iter().map(|e| e.place()).collect();
        let n = places.len();
        places.dedup();
        assert_eq!(places.len(), n, "two lab sides share a place: {places:?}");
    }

    #[test]
    fn the_power_stage_has_one_place_per_effect() {
        let mut stages: Vec<u8> = REGISTRY.iter().filter_map(|e| e.command_stage()).collect();
        let n = stages.len();
        stages.sort_unstable();
        stages.dedup();
        assert_eq!(stages.len(), n);
    }

    /// Every parameter an effect's lab side names exists in a model with that effect, on every
    /// family that supports it: the balance, the grids and the evidence are built without error.
    #[test]
    fn every_lab_side_finds_its_parameters_on_every_family() {
        use crate::lab::regress::{balance, grid_for};
        let n = 2000;
        let time: Vec<f64> = (0..n).map(|k| k as f64 * 1e-3).collect();
        let wave = |f: f64, a: f64| time.iter().map(|t| a * (f * t).sin()).collect::<Vec<f64>>();
        for family in [
            Family::LinearAxis,
            Family::Solenoid,
            Family::Pneumatic,
            Family::MotorGear,
        ] {
            let supply_nominal = match family {
                Family::Pneumatic => 60_000.0,
                _ => 24.0,
            };
            let raw = Dataset {
                origin: "t".into(),
                time: time.clone(),
                input: wave(7.0, 0.5),
                output: wave(3.0, 0.01),
                supply: Some(
                    wave(1.0, 0.1 * supply_nominal)
                        .iter()
                        .map(|x| x + supply_nominal)
                        .collect(),
                ),
                current: None,
            };
            let d = crate::lab::signals::prepare(&raw, None);
            for &kind in EffectKind::ALL {
                if !kind.supported_by(family) {
                    continue;
                }
                let lab = of(kind).expect("lab side");
                if !lab.representable(family, &d) {
                    continue;
                }
                let spec = PlantSpec::new(family).with_effect(kind).expect("supported");
                let bal = balance(&spec, &raw, &d)
                    .unwrap_or_else(|e| panic!("{family} with {kind}: {e:#}"));
                grid_for(&spec, kind, &d, &raw)
                    .unwrap_or_else(|e| panic!("{family} with {kind}: grid: {e:#}"));
                let fit = bal.evaluate();
                let ev = Evidence {
                    family,
                    base: &fit,
                    data: &raw,
                    d: &d,
                    unit: "N",
                };
                assert!(!lab.evidence(&ev).is_empty(), "{family} with {kind}");
            }
        }
    }

    #[test]
    fn correlation_of_proportional_and_opposite_series() {
        let x: Vec<f64> = (0..50).map(|k| (k as f64 * 0.3).sin()).collect();
        let y: Vec<f64> = x.iter().map(|v| 3.0 * v + 1.0).collect();
        let z: Vec<f64> = x.iter().map(|v| -v).collect();
        assert!((corr(&x, &y) - 1.0).abs() < 1e-12);
        assert!((corr(&x, &z) + 1.0).abs() < 1e-12);
        assert_eq!(corr(&x, &[1.0; 50]), 0.0);
    }

    #[test]
    fn mean_where_counts_the_selected_samples() {
        let r = [1.0, 2.0, 3.0, 4.0];
        let idx = [10, 11, 12, 13];
        assert_eq!(mean_where(&r, &idx, |k| k >= 12), (3.5, 2));
        assert_eq!(mean_where(&r, &idx, |_| false), (0.0, 0));
    }
}
