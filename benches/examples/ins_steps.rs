//! Runs INS predicts and position updates in a loop, for an instruction-count
//! profile under callgrind (this VM has no hardware counters, and time varies):
//!
//! ```sh
//! cargo build --release -p fusion-benches --example ins_steps
//! valgrind --tool=callgrind --callgrind-out-file=/tmp/cg.out target/release/examples/ins_steps 10000
//! callgrind_annotate /tmp/cg.out
//! ```

use std::hint::black_box;

use fusion_benches::{ins_fix, ins_imu, ins_model};
use fusion_daemon::filter::ChiSquareGate;
use fusion_daemon::measurement::Steps;
use fusion_daemon::model::Model;
use fusion_daemon::model::ins::InsModel;
use fusion_shared::Sample;

fn main() {
    let n: u64 = std::env::args().nth(1).and_then(|a| a.parse().ok()).unwrap_or(10_000);
    let timed = std::env::args().nth(2).is_some_and(|a| a == "time");
    let model = ins_model();
    let (imu, pos) = (ins_imu, ins_fix);
    let mut state = model.initial_state();
    model.step(&mut state, &imu(0));
    let mut t = 0;
    if !timed {
        for _ in 0..n {
            t += 5_000_000;
            black_box(predict(&model, &mut state, &imu(t)));
        }
        let base = state;
        for _ in 0..n {
            let mut s = black_box(base);
            black_box(update(&model, &mut s, &pos(t)));
        }
        let gate = fusion_daemon::filter::ChiSquareGate::new(0.999).expect("valid probability");
        for _ in 0..n {
            let mut kf = black_box(*base.filter());
            black_box(filter_update(&mut kf, &gate));
        }
        return;
    }
    // Batches of 1000 steps, alternating predict and update, `n` rounds: this
    // VM's noise only ever adds time, so the minimum and the lower quartile over
    // the rounds are the stable figures.
    let base = state;
    let (mut p, mut u, mut c, mut k) = (Vec::new(), Vec::new(), Vec::new(), Vec::new());
    let kf = *base.filter();
    let gate = ChiSquareGate::new(0.999).expect("valid probability");
    for _ in 0..n {
        let start = std::time::Instant::now();
        for _ in 0..1000 {
            t += 5_000_000;
            black_box(predict(&model, &mut state, &imu(t)));
        }
        p.push(start.elapsed().as_nanos() as f64 / 1000.0);
        let start = std::time::Instant::now();
        for _ in 0..1000 {
            let mut s = black_box(base);
            black_box(update(&model, &mut s, &pos(t)));
        }
        u.push(start.elapsed().as_nanos() as f64 / 1000.0);
        let start = std::time::Instant::now();
        for _ in 0..1000 {
            black_box(black_box(base));
        }
        c.push(start.elapsed().as_nanos() as f64 / 1000.0);
        let start = std::time::Instant::now();
        for _ in 0..1000 {
            let mut f = black_box(kf);
            black_box(filter_update(&mut f, &gate));
        }
        k.push(start.elapsed().as_nanos() as f64 / 1000.0);
    }
    let stats = |v: &mut Vec<f64>| {
        v.sort_by(f64::total_cmp);
        (v[0], v[v.len() / 4], v[v.len() / 2])
    };
    println!("predict ns (min, q1, median): {:.0?}", stats(&mut p));
    println!("update + 2.2 KB state copy ns (min, q1, median): {:.0?}", stats(&mut u));
    println!("2.2 KB state copy alone ns (min, q1, median): {:.0?}", stats(&mut c));
    println!("filter update only (+1.9 KB copy) ns (min, q1, median): {:.0?}", stats(&mut k));
}

#[inline(never)]
fn predict(model: &InsModel, s: &mut <InsModel as Model>::State, sample: &Sample) -> fusion_daemon::model::StepOutcome {
    model.step(s, sample)
}

#[inline(never)]
fn update(model: &InsModel, s: &mut <InsModel as Model>::State, sample: &Sample) -> fusion_daemon::model::StepOutcome {
    // Not the same body as `predict`, or the linker folds the two into one symbol.
    black_box(1u8);
    model.step(s, sample)
}

/// The filter's position update alone (no injection, no reset), as the model calls it.
#[inline(never)]
fn filter_update(kf: &mut fusion_daemon::filter::KalmanFilter<f64, 15>, gate: &ChiSquareGate) -> bool {
    let z = nalgebra::Vector3::new(0.045, 0.0, 0.0);
    let r = nalgebra::Matrix3::new(0.25, 0.0, 0.0, 0.0, 0.25, 0.0, 0.0, 0.0, 0.64);
    let predicted = nalgebra::Vector3::new(kf.x()[0], kf.x()[1], kf.x()[2]);
    kf.update_selection_lean(&z, &predicted, 0, &r, Some(gate)).is_ok()
}
