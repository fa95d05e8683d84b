//! The second-order certificate of a case as a machine-readable record and a text table.

use serde::Serialize;

use super::summary::{finite_or_null, opt_finite_or_null};
use crate::lie::certify::SuslovCertificate;
use crate::ocp::MultiplierStart;

/// One case of `suslov certify` (serialized into `certificate.json`).
#[derive(Debug, Clone, Default, Serialize)]
pub struct CertificateReport {
    /// Case name.
    pub name: String,
    /// `"certified"`, `"not_minimum"`, `"degenerate"`, or `"error"` (see `message`).
    pub verdict: String,
    /// The verdict in words, or the error.
    pub message: String,
    /// Terminal time `b` of the certified point.
    #[serde(with = "finite_or_null")]
    pub terminal_time: f64,
    /// Whether `b` was an unknown.
    pub free_time: bool,
    /// Cost of the certified point.
    #[serde(with = "finite_or_null")]
    pub cost: f64,
    /// Mesh intervals (the solution's own mesh).
    pub intervals: usize,
    /// Unknowns of the discretized problem.
    pub unknowns: usize,
    /// Equality constraints of the discretized problem.
    pub constraints: usize,
    /// KKT stationarity residual of the indirect solution (relative to `‖∇J‖∞`), with the
    /// multipliers its costates give (least-squares multipliers where Newton's method failed
    /// from those).
    #[serde(with = "finite_or_null")]
    pub candidate_stationarity: f64,
    /// Constraint residual of the indirect solution in the direct discretization.
    #[serde(with = "finite_or_null")]
    pub candidate_feasibility: f64,
    /// Where the multipliers of `candidate_stationarity` (Newton's start) came from:
    /// `"costates"` (the indirect solution's, from κ) or `"least_squares"`.
    pub candidate_multipliers: Option<MultiplierStart>,
    /// Newton iterations to the exact KKT point of the discretized problem.
    pub newton_iterations: usize,
    /// `‖v* − v₀‖∞`, certified point against the indirect solution.
    #[serde(with = "finite_or_null")]
    pub displacement: f64,
    /// KKT stationarity residual (relative) at the certified point.
    #[serde(with = "finite_or_null")]
    pub kkt_stationarity: f64,
    /// Constraint residual at the certified point.
    #[serde(with = "finite_or_null")]
    pub kkt_feasibility: f64,
    /// Multipliers read as costates against the classical costates from κ (relative).
    #[serde(with = "finite_or_null")]
    pub costate_mismatch: f64,
    /// Inertia of the KKT matrix `[positive, negative, zero]`; certified ⇔
    /// `[unknowns, constraints, 0]`.
    pub inertia: [usize; 3],
    /// Negative eigenvalues of the reduced Hessian.
    pub negative_curvature_directions: usize,
    /// Lower end of the bracket of the smallest eigenvalue of the reduced Hessian in the
    /// metric `∫|δξ̇|² dt + |δξ(a)|² (+ δb²)`.
    #[serde(with = "opt_finite_or_null")]
    pub margin_low: Option<f64>,
    /// Upper end of that bracket.
    #[serde(with = "opt_finite_or_null")]
    pub margin_high: Option<f64>,
    /// Rayleigh quotient of the computed weakest direction (≈ the margin).
    #[serde(with = "opt_finite_or_null")]
    pub weakest_rayleigh: Option<f64>,
    /// Time where the weakest direction's `|δξ̇|²` peaks.
    #[serde(with = "opt_finite_or_null")]
    pub weakest_peak_time: Option<f64>,
    /// Fraction of the weakest direction in `δξ(a)` and the first 5 % of `[a, b]`.
    #[serde(with = "opt_finite_or_null")]
    pub weakest_start_fraction: Option<f64>,
    /// Fraction of it in `δξ(a)` alone.
    #[serde(with = "opt_finite_or_null")]
    pub weakest_initial_xi_fraction: Option<f64>,
    /// Fraction of it in the last 5 % of `[a, b]`.
    #[serde(with = "opt_finite_or_null")]
    pub weakest_end_fraction: Option<f64>,
    /// The first discrete conjugate point `t_j` (variations with fixed ends on `[a, t_j]`
    /// lower the cost), `null` if there is none up to `b`.
    #[serde(with = "opt_finite_or_null")]
    pub conjugate_time: Option<f64>,
    /// Backward error of the `LBLᵀ` factorization the verdict rests on.
    #[serde(with = "finite_or_null")]
    pub backward_error: f64,
    /// Set when the certified point is visibly different from the computed solution.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub warning: Option<String>,
    /// The a-posteriori verification of the solution that was certified, as a case status:
    /// `"converged"` or `"unverified: …"` (absent when there was no solution). The certificate
    /// is about the discretized problem on the solution's mesh; an unverified solution is not
    /// an accurate extremal of the continuous problem.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub solution_status: Option<String>,
    /// Wall time of the solve, seconds.
    pub solve_seconds: f64,
    /// Wall time of the certificate, seconds.
    pub certify_seconds: f64,
}

impl CertificateReport {
    /// The record of a certificate.
    pub fn from_certificate(name: &str, c: &SuslovCertificate) -> Self {
        let so = &c.certificate.second_order;
        let verdict = serde_json::to_value(so.verdict)
            .ok()
            .and_then(|v| v.as_str().map(str::to_string))
            .unwrap_or_default();
        Self {
            name: name.to_string(),
            verdict,
            message: so.verdict.sentence().to_string(),
            terminal_time: c.terminal_time,
            free_time: c.free_time,
            cost: c.cost,
            intervals: c.intervals,
            unknowns: so.n_var,
            constraints: so.n_con,
            candidate_stationarity: c.certificate.candidate.relative_stationarity(),
            candidate_feasibility: c.certificate.candidate.feasibility,
            candidate_multipliers: Some(c.certificate.multipliers_from),
            newton_iterations: c.certificate.newton_iterations,
            displacement: c.certificate.displacement,
            kkt_stationarity: c.certificate.kkt.relative_stationarity(),
            kkt_feasibility: c.certificate.kkt.feasibility,
            costate_mismatch: c.costate_mismatch,
            inertia: [so.inertia.positive, so.inertia.negative, so.inertia.zero],
            negative_curvature_directions: so.negative_curvature_directions,
            margin_low: so.margin.map(|m| m.0),
            margin_high: so.margin.map(|m| m.1),
            backward_error: so.backward_error,
            conjugate_time: c.certificate.conjugate.first.map(|p| p.time),
            weakest_rayleigh: so.weakest_rayleigh,
            weakest_peak_time: c.weakest.map(|w| w.peak_time),
            weakest_start_fraction: c.weakest.map(|w| w.start_fraction),
            weakest_initial_xi_fraction: c.weakest.map(|w| w.initial_state_fraction),
            weakest_end_fraction: c.weakest.map(|w| w.end_fraction),
            warning: c.warning(),
            ..Default::default()
        }
    }

    /// The record of a case that could not be certified (solve or certificate failed).
    pub fn error(name: &str, message: String) -> Self {
        Self {
            name: name.to_string(),
            verdict: "error".to_string(),
            message,
            terminal_time: f64::NAN,
            cost: f64::NAN,
            candidate_stationarity: f64::NAN,
            candidate_feasibility: f64::NAN,
            displacement: f64::NAN,
            kkt_stationarity: f64::NAN,
            kkt_feasibility: f64::NAN,
            costate_mismatch: f64::NAN,
            backward_error: f64::NAN,
            ..Default::default()
        }
    }

    /// A few lines for people.
    pub fn text(&self) -> String {
        let unverified = self
            .solution_status
            .as_ref()
            .filter(|s| s.as_str() != "converged")
            .map(|s| {
                format!(
                    "  warning: the solution did not pass its a-posteriori checks ({s}); the \
                     certificate is about its discretization only\n"
                )
            })
            .unwrap_or_default();
        if self.verdict == "error" {
            return format!(
                "case {}: no verdict: {}\n{unverified}",
                self.name, self.message
            );
        }
        let margin = match (self.margin_low, self.margin_high) {
            (Some(lo), Some(hi)) => format!("in [{lo:.4e}, {hi:.4e}]"),
            _ => "not bracketed".to_string(),
        };
        format!(
            "case {name}: {msg}\n\
             \x20 b = {b}{free}, cost = {cost}, {iv} intervals: {nv} unknowns, {nc} constraints\n\
             \x20 indirect solution as a KKT point{with}: stationarity {cs:.1e}, feasibility \
             {cf:.1e}\n\
             \x20 Newton to the exact KKT point: {it} {iterations}, displacement {disp:.1e}, \
             residuals {ks:.1e} / {kf:.1e}\n\
             \x20 multipliers vs costates from kappa: {cm:.1e} (relative)\n\
             \x20 KKT matrix inertia: {p} positive, {n} negative, {z} zero eigenvalues (a strict \
             local minimum has {nv} positive, {nc} negative, 0 zero); {neg} negative curvature \
             direction(s)\n\
             \x20 smallest eigenvalue of the reduced Hessian: {margin}\n\
             \x20 {weak}\n\
             \x20 first conjugate point (fixed-end variations): {conj}\n\
             \x20 LBL^T backward error {be:.1e}; {ss:.2} s solve, {cs2:.2} s certificate\n",
            name = self.name,
            msg = self.message,
            b = super::significant(self.terminal_time, 8),
            free = if self.free_time {
                " (free)"
            } else {
                " (fixed)"
            },
            cost = super::significant(self.cost, 8),
            iv = self.intervals,
            nv = self.unknowns,
            nc = self.constraints,
            with = match self.candidate_multipliers {
                Some(MultiplierStart::Costates) => " (its costates as multipliers)",
                Some(MultiplierStart::LeastSquares) => " (least-squares multipliers)",
                None => "",
            },
            cs = self.candidate_stationarity,
            cf = self.candidate_feasibility,
            it = self.newton_iterations,
            iterations = if self.newton_iterations == 1 {
                "iteration"
            } else {
                "iterations"
            },
            disp = self.displacement,
            ks = self.kkt_stationarity,
            kf = self.kkt_feasibility,
            cm = self.costate_mismatch,
            p = self.inertia[0],
            n = self.inertia[1],
            z = self.inertia[2],
            neg = self.negative_curvature_directions,
            be = self.backward_error,
            weak = match (
                self.weakest_rayleigh,
                self.weakest_peak_time,
                self.weakest_start_fraction,
                self.weakest_initial_xi_fraction,
                self.weakest_end_fraction,
            ) {
                (Some(q), Some(t), Some(s), Some(x), Some(e)) => format!(
                    "weakest direction: Rayleigh quotient {q:.4e}; {:.0} % of it in the first 5 % \
                     of [a, b] (delta xi(a): {:.0} %), {:.0} % in the last 5 %; |delta xi'| peaks \
                     at t = {t:.4}",
                    100.0 * s,
                    100.0 * x,
                    100.0 * e
                ),
                _ => "weakest direction: not computed".to_string(),
            },
            conj = match self.conjugate_time {
                Some(t) => format!("at t = {t:.4}"),
                None => "none up to b".to_string(),
            },
            ss = self.solve_seconds,
            cs2 = self.certify_seconds,
        ) + &self
            .warning
            .as_ref()
            .map(|w| format!("  warning: {w}\n"))
            .unwrap_or_default()
            + &unverified
    }
}
