//! The paper's problem (section 5.3) for the generic layer (`suslov::lie`) of any so(3)-like
//! model, shared by `tests/lie_layer.rs` and `tests/lie_inhomogeneous.rs`.
#![allow(dead_code)]

use std::collections::HashMap;
use std::sync::Arc;

use suslov::lie::path::Path as LiePath;
use suslov::lie::Problem;
use suslov::model::Model;
use suslov::so3::desired::DesiredPath;
use suslov::so3::paper;

/// An so(3) desired path as a path of the generic layer (test adapter).
pub struct So3Path(pub Arc<dyn DesiredPath + Send + Sync>);

impl LiePath for So3Path {
    fn dim(&self) -> usize {
        3
    }
    fn jet_into(&self, t: f64, out: &mut [f64]) {
        let j = self.0.jet(t);
        for (k, v) in [j.value, j.d1, j.d2, j.d3].iter().enumerate() {
            out[3 * k..3 * k + 3].copy_from_slice(v.as_slice());
        }
    }
    fn value_into(&self, t: f64, out: &mut [f64]) {
        out.copy_from_slice(self.0.value(t).as_slice());
    }
}

/// The paper's problem with smoothing weight `eta` for model `M` (principal moments `I1`,
/// `I2`, `I3`, the weights by name, a constraint value `c` = 0 where the model has one).
pub fn paper_problem<M: Model>(eta: f64) -> Problem<M> {
    let p = paper::problem(eta);
    let by_name: HashMap<&str, f64> = HashMap::from([
        ("I1", p.inertia.diag()[0]),
        ("I2", p.inertia.diag()[1]),
        ("I3", p.inertia.diag()[2]),
        ("alpha", p.weights.alpha),
        ("beta", p.weights.beta),
        ("gamma", p.weights.gamma),
        ("eta", p.weights.eta),
        ("delta", p.weights.delta),
        ("c", 0.0),
    ]);
    let user: Vec<f64> = M::PARAM_NAMES[..M::N_USER_PARAM]
        .iter()
        .map(|n| by_name[n])
        .collect();
    Problem::new(
        &user,
        p.t0,
        p.omega_a.as_slice().to_vec(),
        p.omega_b.as_slice().to_vec(),
        p.terminal,
        Arc::new(So3Path(p.desired.clone())),
    )
    .expect("the paper's problem is valid")
}
