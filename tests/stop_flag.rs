//! `SolveOptions::stop`: a solve stops when its flag is set (here from the event callback, after
//! the first accepted continuation step), returns the last converged point with a reason that
//! says so, and tries no other route; an unset flag changes nothing (the same b and J, bit for
//! bit).

use suslov::lie::solve::{Event, StopFlag};
use suslov::{paper, solve, SolveError, SolveOptions};

#[test]
fn a_set_flag_stops_the_solve_at_its_last_converged_point() {
    let stop = StopFlag::new();
    let options = SolveOptions {
        stop: Some(stop.clone()),
        ..Default::default()
    };
    let mut steps_after_stop = 0;
    let result = solve(&paper::problem(1.0), &options, &mut |e| {
        if let Event::Step { record, .. } = e {
            if stop.is_stopped() {
                steps_after_stop += 1;
            }
            if record.accepted {
                stop.stop();
            }
        }
    });
    let Err(SolveError::StageFailed {
        stage,
        reason,
        partial,
        ..
    }) = result
    else {
        panic!("expected a stop, got {result:?}");
    };
    assert_eq!(stage, "beta");
    assert!(reason.contains("stopped by the caller"), "{reason}");
    // No further continuation step after the stop (the step in progress was the last one),
    // and no other route.
    assert_eq!(steps_after_stop, 0);
    assert_eq!(
        partial.generic.routes.len(),
        1,
        "{:?}",
        partial.generic.routes
    );
    assert!(partial.generic.collapse.is_none());
    assert!(partial.terminal_time().is_finite());
}

#[test]
fn an_unset_flag_changes_nothing() {
    let plain = solve(&paper::problem(0.01), &SolveOptions::default(), &mut |_| {}).unwrap();
    let options = SolveOptions {
        stop: Some(StopFlag::new()),
        ..Default::default()
    };
    let flagged = solve(&paper::problem(0.01), &options, &mut |_| {}).unwrap();
    assert_eq!(
        plain.terminal_time().to_bits(),
        flagged.terminal_time().to_bits()
    );
    assert_eq!(plain.cost().to_bits(), flagged.cost().to_bits());
}
