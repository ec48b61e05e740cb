//! One linear dynamical system (LDS) fitted to a simple trajectory (dissertation chapter 5,
//! §5.3–5.6).
//!
//! A trajectory `x_0 … x_N` that ends at its attractor `x_N` is modelled as
//! `x_{n+1} = R (x_n − x_N) + x_n` (Eq. 5.1). `R` is the least-squares solution of the stacked
//! equation (Eq. 5.2) with the right pseudo-inverse, `R̂ = (X_{1:N} − X_{0:N−1})(X_{0:N−1} − Γ_N)^R`
//! (Eq. 5.3); several demonstrations, each with its own attractor, are stacked side by side
//! (Eq. 5.5). Reproduction iterates the induced control law `x̂_{n+1} = R̂ (x̂_n − a) + x̂_n`
//! (Eq. 5.4) until `‖x̂_n − a‖ ≤ ζ`.
//!
//! **Stability.** With `Δ_{0:N−1}` the stacked `δ_n = x_n − x_N` of full row rank, `I + R̂` is
//! convergent (Theorem 5.2; with `P = Δ_{0:N−1} Δ_{0:N−1}ᵀ`, `P − (I+R̂) P (I+R̂)ᵀ ⪰ δ_0 δ_0ᵀ`,
//! and no left eigenvector of modulus one can be orthogonal to every `δ_n`).
//!
//! **Rank.** A taught trajectory rarely fills all six dimensions of the state (a straight line
//! fills one, a planar curve two). Where `Δ_{0:N−1}` is rank deficient the dissertation's estimate
//! is ill-conditioned and is replaced by a scaled identity (§5.6). We go one step further: the fit
//! is made in the subspace the trajectory spans (the singular directions of `Δ_{0:N−1}` above
//! `rank_tolerance` times the largest) and the scaled identity `−α I` acts only on the rest. In the
//! spanned subspace the fit is Eq. 5.3 of the projected trajectory, whose `Δ` has full row rank
//! there, so Theorem 5.2 holds for it; `R̂` is block-triangular in (spanned, rest), so its spectrum
//! is that of the projected fit and `−α`, with `α ∈ (0, 1]`: the control law still converges to the
//! attractor from any start. The dissertation's rule stays on top: an `R̂` whose condition number
//! exceeds `κ_max` is replaced by `−α I` whole (straight lines to the attractor). `α` is the
//! least-squares scalar fit of the same data, clamped to `[ALPHA_MIN, 1]`.

use nalgebra::{SMatrix, SVector, SymmetricEigen};
use serde::{Deserialize, Serialize};
use thiserror::Error;

/// Dimension of the state: position (mm) and scaled rotation vector (mm, see
/// [`super::segment`]).
pub const DIM: usize = 6;

/// A state of the trajectory.
pub type State = SVector<f64, DIM>;
/// The dynamics matrix `R`.
pub type Dynamics = SMatrix<f64, DIM, DIM>;

/// The smallest rate a scaled identity may take: 0.1 % of the remaining distance per step.
pub const ALPHA_MIN: f64 = 1e-3;

/// How an LDS is fitted.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct FitSettings {
    /// Largest condition number of `R̂` kept; above it `R̂` becomes `−α I` (§5.6).
    pub kappa_max: f64,
    /// Singular directions of `Δ` below this fraction of the largest are not fitted.
    pub rank_tolerance: f64,
    /// Nor are directions along which the states' root-mean-square distance from the attractor
    /// is below this (mm): there the data are noise, and a fit of noise makes the least-squares
    /// step swing with every sample. 0 fits every direction above `rank_tolerance`.
    pub min_extent: f64,
}

impl Default for FitSettings {
    fn default() -> Self {
        FitSettings {
            kappa_max: 1e4,
            rank_tolerance: 1e-3,
            min_extent: 0.0,
        }
    }
}

/// What cannot be fitted.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum FitError {
    #[error("a demonstration needs at least two samples, one has {0}")]
    TooShort(usize),
    #[error("a demonstration's samples have a non-finite component")]
    NonFinite,
    #[error("no demonstration to fit")]
    Empty,
    #[error("kappa_max must be at least 1, rank_tolerance in (0, 1) and min_extent non-negative")]
    Settings,
}

/// Running sums of the least-squares problem: pairs `(x_k, x_{k+1})` with inputs relative to an
/// origin, so the attractor can be chosen after the pairs are added (the online segmentation
/// tries a new attractor at every sample). With `δ_k = x_k − a` and `d_k = x_{k+1} − x_k`:
/// `Σ δδᵀ = S_xx − a s_xᵀ − s_x aᵀ + m a aᵀ`, `Σ d δᵀ = S_dx − s_d aᵀ`.
#[derive(Debug, Clone)]
pub struct Sums {
    origin: State,
    m: f64,
    sx: State,
    sxx: Dynamics,
    sd: State,
    sdx: Dynamics,
}

impl Sums {
    /// Empty sums; inputs are taken relative to `origin` (any nearby state: it only keeps the
    /// sums well conditioned).
    pub fn new(origin: State) -> Sums {
        Sums {
            origin,
            m: 0.0,
            sx: State::zeros(),
            sxx: Dynamics::zeros(),
            sd: State::zeros(),
            sdx: Dynamics::zeros(),
        }
    }

    /// Adds the step `from → to`.
    pub fn add(&mut self, from: &State, to: &State) {
        let x = from - self.origin;
        let d = to - from;
        self.m += 1.0;
        self.sx += x;
        self.sxx += x * x.transpose();
        self.sd += d;
        self.sdx += d * x.transpose();
    }

    /// Adds every step of a demonstration.
    pub fn add_demo(&mut self, demo: &[State]) {
        for w in demo.windows(2) {
            self.add(&w[0], &w[1]);
        }
    }

    /// Number of steps added.
    pub fn pairs(&self) -> usize {
        self.m as usize
    }

    /// `(Σ δδᵀ, Σ d δᵀ)` for the attractor `a`.
    fn moments(&self, a: &State) -> (Dynamics, Dynamics) {
        let a = a - self.origin;
        let g = self.sxx - a * self.sx.transpose() - self.sx * a.transpose()
            + a * a.transpose() * self.m;
        let h = self.sdx - self.sd * a.transpose();
        (g, h)
    }

    /// The LDS for the attractor `a` (Eq. 5.3 in the spanned subspace, see the module docs).
    pub fn fit(&self, a: &State, settings: &FitSettings) -> Fit {
        let (g, h) = self.moments(a);
        fit_moments(g, h, self.m, settings)
    }
}

/// The LDS from `G = Σ δδᵀ` and `H = Σ d δᵀ` (see the module docs).
fn fit_moments(g: Dynamics, h: Dynamics, pairs: f64, settings: &FitSettings) -> Fit {
    let g = (g + g.transpose()) * 0.5;
    let trace_g = g.trace();
    let alpha = if trace_g > 0.0 {
        (-h.trace() / trace_g).clamp(ALPHA_MIN, 1.0)
    } else {
        1.0
    };
    let identity = -Dynamics::identity() * alpha;
    let eig = SymmetricEigen::new(g);
    let largest = eig.eigenvalues.max();
    if largest.is_nan() || largest <= 0.0 {
        return Fit {
            r: identity,
            alpha,
            rank: 0,
            condition: f64::INFINITY,
            identity: true,
        };
    }
    // Eigenvalues of G are squared singular values of Δ.
    let floor = (largest * settings.rank_tolerance * settings.rank_tolerance)
        .max(pairs * settings.min_extent * settings.min_extent);
    let mut pinv = Dynamics::zeros();
    let mut projector = Dynamics::zeros();
    let mut rank = 0;
    for (i, &lambda) in eig.eigenvalues.iter().enumerate() {
        if lambda > floor {
            let u = eig.eigenvectors.column(i);
            let uu = u * u.transpose();
            pinv += uu / lambda;
            projector += uu;
            rank += 1;
        }
    }
    let fitted = h * pinv;
    let r = fitted - (Dynamics::identity() - projector) * alpha;
    let condition = condition_number(&r);
    if condition.is_nan() || condition > settings.kappa_max {
        return Fit {
            r: identity,
            alpha,
            rank,
            condition,
            identity: true,
        };
    }
    Fit {
        r,
        alpha,
        rank,
        condition,
        identity: false,
    }
}

/// A fitted `R̂` and how it was obtained.
#[derive(Debug, Clone, PartialEq)]
pub struct Fit {
    pub r: Dynamics,
    /// Rate of the scaled identity (used outside the spanned subspace, or for all of `R̂`).
    pub alpha: f64,
    /// Dimension of the subspace the demonstrations span (fitted by least squares).
    pub rank: usize,
    /// Condition number of the least-squares `R̂` (before any replacement).
    pub condition: f64,
    /// `R̂` was replaced by `−α I` (κ above `κ_max`, or nothing to fit).
    pub identity: bool,
}

impl Fit {
    /// Fits one LDS to demonstrations that each end at their own attractor (Eq. 5.3; several
    /// demonstrations stacked as in Eq. 5.5).
    pub fn demonstrations(demos: &[&[State]], settings: &FitSettings) -> Result<Fit, FitError> {
        if !(settings.kappa_max >= 1.0
            && settings.rank_tolerance > 0.0
            && settings.rank_tolerance < 1.0
            && settings.min_extent >= 0.0)
        {
            return Err(FitError::Settings);
        }
        let first = demos.first().ok_or(FitError::Empty)?;
        let origin = *first.last().ok_or(FitError::TooShort(0))?;
        // Each demonstration has its own attractor: Σδδᵀ and Σdδᵀ add up over them.
        let mut g = Dynamics::zeros();
        let mut h = Dynamics::zeros();
        let mut pairs = 0.0;
        for demo in demos {
            if demo.len() < 2 {
                return Err(FitError::TooShort(demo.len()));
            }
            if demo.iter().any(|x| x.iter().any(|v| !v.is_finite())) {
                return Err(FitError::NonFinite);
            }
            let mut one = Sums::new(origin);
            one.add_demo(demo);
            let (gi, hi) = one.moments(&demo[demo.len() - 1]);
            g += gi;
            h += hi;
            pairs += one.m;
        }
        Ok(fit_moments(g, h, pairs, settings))
    }

    /// Spectral radius of `I + R̂` (below one: the control law converges).
    pub fn spectral_radius(&self) -> f64 {
        spectral_radius(&(Dynamics::identity() + self.r))
    }

    /// Reproduces the trajectory from `start` towards `attractor` with the control law (Eq. 5.4)
    /// until within `zeta` of it, or `max_steps` steps.
    pub fn reproduce(
        &self,
        start: &State,
        attractor: &State,
        zeta: f64,
        max_steps: usize,
    ) -> Reproduced {
        let mut x = *start;
        let mut path = vec![x];
        let mut converged = (x - attractor).norm() <= zeta;
        while !converged && path.len() <= max_steps {
            x += self.r * (x - attractor);
            if x.iter().any(|v| !v.is_finite()) {
                break;
            }
            path.push(x);
            converged = (x - attractor).norm() <= zeta;
        }
        Reproduced { path, converged }
    }
}

/// The states of a reproduction, `start` first.
#[derive(Debug, Clone, PartialEq)]
pub struct Reproduced {
    pub path: Vec<State>,
    /// The last state is within ζ of the attractor.
    pub converged: bool,
}

fn condition_number(r: &Dynamics) -> f64 {
    let s = r.singular_values();
    let (max, min) = (s.max(), s.min());
    if min > 0.0 { max / min } else { f64::INFINITY }
}

fn spectral_radius(a: &Dynamics) -> f64 {
    a.complex_eigenvalues()
        .iter()
        .map(|c| c.norm())
        .fold(0.0, f64::max)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn state(x: f64, y: f64) -> State {
        State::from_column_slice(&[x, y, 0.0, 0.0, 0.0, 0.0])
    }

    #[test]
    fn a_decaying_line_is_fitted_exactly_and_reproduced() {
        // x_{n+1} = x_n + R (x_n − a) with R = −0.2 I along a line: the fit recovers the rate.
        let a = state(100.0, 50.0);
        let mut demo = vec![state(0.0, 0.0)];
        for _ in 0..30 {
            let x = *demo.last().unwrap();
            demo.push(x - (x - a) * 0.2);
        }
        let last = *demo.last().unwrap();
        let fit = Fit::demonstrations(&[&demo], &FitSettings::default()).unwrap();
        let along = (a - demo[0]).normalize();
        assert!(
            ((fit.r * along).dot(&along) + 0.2).abs() < 1e-3,
            "{}",
            fit.r
        );
        let out = fit.reproduce(&demo[0], &last, 0.5, 10_000);
        assert!(out.converged);
        assert!(fit.spectral_radius() < 1.0);
    }

    #[test]
    fn ill_conditioned_fits_become_a_scaled_identity() {
        // A curve that slows down hard in one direction: R has a large and a small gain.
        let demo: Vec<State> = (0..20)
            .map(|i| {
                let k = (19 - i) as f64;
                state(k, 0.5 * k * k)
            })
            .collect();
        let fitted = Fit::demonstrations(&[&demo], &FitSettings::default()).unwrap();
        assert!(!fitted.identity);
        assert!(fitted.condition > 1.5, "{}", fitted.condition);
        let settings = FitSettings {
            kappa_max: fitted.condition * 0.9,
            ..FitSettings::default()
        };
        let fit = Fit::demonstrations(&[&demo], &settings).unwrap();
        assert!(fit.identity);
        assert_eq!(fit.r, -Dynamics::identity() * fit.alpha);
        assert!(fit.alpha > 0.0 && fit.alpha <= 1.0);
    }

    #[test]
    fn bad_input_is_refused() {
        let s = FitSettings::default();
        assert_eq!(Fit::demonstrations(&[], &s), Err(FitError::Empty));
        assert_eq!(
            Fit::demonstrations(&[&[state(0.0, 0.0)]], &s),
            Err(FitError::TooShort(1))
        );
        let nan = [state(0.0, 0.0), state(f64::NAN, 0.0)];
        assert_eq!(Fit::demonstrations(&[&nan], &s), Err(FitError::NonFinite));
    }
}
