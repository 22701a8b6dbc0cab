//! Filter-step and replay-throughput benchmarks (criterion).

#![allow(missing_docs)]

use std::hint::black_box;

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use fusion_benches::precision::{InsRun, LinearRun, StudyRun, drives};
use fusion_benches::{bench_drive, ins_config_text, ins_fix, ins_imu, ins_model, linear_config};
use fusion_daemon::config::Config;
use fusion_daemon::engine::{Engine, EngineConfig};
use fusion_daemon::filter::Form;
use fusion_daemon::measurement::Steps;
use fusion_daemon::model::Model;
use fusion_daemon::model::ins::InsModel;
use fusion_daemon::model::linear::LinearModel;
use fusion_daemon::replay::replay;
use fusion_shared::jsonl::format_sample;
use fusion_shared::{ImuSample, PositionSample, Sample};

fn linear_steps(c: &mut Criterion) {
    let config = linear_config();
    let model = LinearModel::from_config(&config).unwrap();
    let imu = |t: u64| {
        Sample::Imu(ImuSample {
            header: fusion_shared::SampleHeader::new(fusion_shared::SampleKind::Imu, t, 0, 0),
            accel_mps2: [0.1, -0.2, 0.05],
            ..Default::default()
        })
    };
    let pos = |t: u64| {
        Sample::Position(PositionSample {
            header: fusion_shared::SampleHeader::new(fusion_shared::SampleKind::Position, t, 0, 0),
            pos_m: [0.01, 0.02, -0.01],
            cov_m2: [0.25, 0.0, 0.0, 0.0, 0.25, 0.0, 0.0, 0.0, 0.64],
        })
    };
    let mut state = model.initial_state();
    model.step(&mut state, &imu(0));
    let mut group = c.benchmark_group("linear");
    let mut t = 0;
    group.bench_function("predict (IMU step)", |b| {
        b.iter(|| {
            t += 1_000_000;
            black_box(model.step(&mut state, black_box(&imu(t))))
        })
    });
    // Position at the filter time: the update alone.
    let base = state;
    // Each iteration restores the start state from a hot copy first, as the engine
    // does before every step (the linear state is 0.4 KB).
    let mut scratch = base;
    group.bench_function("update (position at filter time, plus state copy)", |b| {
        b.iter(|| {
            scratch = black_box(base);
            black_box(model.step(&mut scratch, black_box(&pos(t))))
        })
    });
    group.bench_function("predict + update (plus state copy)", |b| {
        b.iter(|| {
            scratch = black_box(base);
            black_box(model.step(&mut scratch, black_box(&pos(t + 1_000_000))))
        })
    });
    group.finish();
}

fn ins_steps(c: &mut Criterion) {
    let model = ins_model();
    let (imu, pos) = (ins_imu, ins_fix);
    let mut state = model.initial_state();
    model.step(&mut state, &imu(0));
    let mut group = c.benchmark_group("ins");
    let mut t = 0;
    group.bench_function("predict (IMU step, 15 error states)", |b| {
        b.iter(|| {
            t += 5_000_000;
            black_box(model.step(&mut state, black_box(&imu(t))))
        })
    });
    let base = state;
    // Each iteration restores the start state from a hot copy first, as the engine
    // does before every step; "state copy" alone is measured below to subtract.
    // (Restoring outside the timed part, iter_batched_ref, measures a cold state
    // instead: about 0.2 µs more, which the live path never pays.)
    let mut scratch = base;
    group.bench_function("update (position at filter time, with injection and reset, plus state copy)", |b| {
        b.iter(|| {
            scratch = black_box(base);
            black_box(model.step(&mut scratch, black_box(&pos(t))))
        })
    });
    group.bench_function("state copy (2.2 KB)", |b| {
        b.iter(|| {
            scratch = black_box(base);
            black_box(&scratch);
        })
    });
    group.finish();
}

/// The `[filter] form`s in the daemon's models (f64), and both forms in f32 and
/// f64 through the study's runs (`fusion_benches::precision`: dense predicts,
/// the same in every scalar type and form).
fn forms(c: &mut Criterion) {
    let mut group = c.benchmark_group("forms");
    for form in ["joseph", "udu"] {
        let text = ins_config_text().replacen("[filter]\n", &format!("[filter]\nform = \"{form}\"\n"), 1);
        let model = InsModel::from_config(&Config::parse(&text).unwrap()).unwrap();
        let mut state = model.initial_state();
        model.step(&mut state, &ins_imu(0));
        let mut t = 0;
        group.bench_function(format!("ins model, {form}: predict (IMU step)"), |b| {
            b.iter(|| {
                t += 5_000_000;
                black_box(model.step(&mut state, black_box(&ins_imu(t))))
            })
        });
        let (base, mut scratch) = (state, state);
        group.bench_function(format!("ins model, {form}: update (fix, plus state copy)"), |b| {
            b.iter(|| {
                scratch = black_box(base);
                black_box(model.step(&mut scratch, black_box(&ins_fix(t))))
            })
        });
    }
    let (_, lin) = drives::linear(1.0, 0.5, 1);
    let (_, ins) = drives::ins(1.0, 0.5, 1);
    for form in [Form::Joseph, Form::Udu] {
        study_steps(&mut group, "linear f64", form, LinearRun::<f64>::new(&lin, form));
        study_steps(&mut group, "linear f32", form, LinearRun::<f32>::new(&lin, form));
        study_steps(&mut group, "ins f64", form, InsRun::<f64>::new(&ins, form));
        study_steps(&mut group, "ins f32", form, InsRun::<f32>::new(&ins, form));
    }
    group.finish();
}

/// Predict and update of a study run.
fn study_steps<R: StudyRun + Clone>(
    group: &mut criterion::BenchmarkGroup<'_, criterion::measurement::WallTime>,
    name: &str,
    form: Form,
    mut run: R,
) {
    run.step(&ins_imu(0));
    let mut t = 0;
    group.bench_function(format!("{name} {}: predict", form.name()), |b| {
        b.iter(|| {
            t += 5_000_000;
            run.step(black_box(&ins_imu(t)));
        })
    });
    let base = run.clone();
    let mut scratch = run;
    group.bench_function(format!("{name} {}: update (fix, plus state copy)", form.name()), |b| {
        b.iter(|| {
            scratch.clone_from(black_box(&base));
            scratch.step(black_box(&ins_fix(t)));
        })
    });
}

fn replay_throughput(c: &mut Criterion) {
    let drive = bench_drive(20.0);
    let samples: Vec<Sample> = drive.arrivals.iter().map(|a| a.sample).collect();
    let config = linear_config();
    let mut group = c.benchmark_group("replay");
    group.throughput(Throughput::Elements(samples.len() as u64));
    group.sample_size(20);
    group.bench_function("engine, linear, 1 kHz IMU + late 10 Hz positions", |b| {
        b.iter(|| {
            let mut engine =
                Engine::new(LinearModel::from_config(&config).unwrap(), EngineConfig::from_config(&config));
            let mut sink = |e: &fusion_daemon::engine::Entry<_>| {
                black_box(e);
            };
            for s in &samples {
                engine.insert(s, None, &mut sink);
            }
            engine.flush(&mut sink);
        })
    });
    let text: String = samples.iter().map(|s| format_sample(s) + "\n").collect();
    group.bench_function("fusiond replay, JSON lines in and out", |b| {
        b.iter(|| {
            let mut out = Vec::with_capacity(text.len() * 4);
            replay(&config, text.as_bytes(), Some(&mut out), false).unwrap();
            black_box(out.len())
        })
    });
    group.finish();
}

criterion_group! {
    name = benches;
    // Short windows keep the whole `cargo bench` under five minutes; the figures
    // are stable to a few per cent at this length (the VM itself varies more).
    config = Criterion::default().warm_up_time(std::time::Duration::from_secs(1)).measurement_time(std::time::Duration::from_secs(3));
    targets = linear_steps, ins_steps, forms, replay_throughput
}
criterion_main!(benches);
