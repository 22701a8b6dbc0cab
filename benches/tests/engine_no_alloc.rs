//! The engine allocates nothing per sample in steady state, in order or late.
//!
//! The counting allocator of [`fusion_benches::alloc`] counts every allocation
//! made on this thread while samples are inserted after a warm-up.

use fusion_benches::alloc::{Counting, count_this_thread, sizes};
use fusion_client::sim::{Scenario, ScenarioConfig};
use fusion_daemon::config::Config;
use fusion_daemon::engine::{Engine, EngineConfig, Entry, Insert};
use fusion_daemon::measurement::Steps;
use fusion_daemon::model::ins::InsModel;
use fusion_daemon::model::linear::LinearModel;
use fusion_shared::Sample;

#[global_allocator]
static GLOBAL: Counting = Counting;

/// Inserts `samples` into an engine of `model` (a fifth to warm up, then counted)
/// and checks that the counted stretch allocated nothing and held rewinds.
fn steady_state_allocates_nothing<M: Steps>(model: M, config: &Config, samples: &[Sample]) {
    let mut engine = Engine::new(model, EngineConfig::from_config(config));
    let mut finals = 0u64;
    let mut sink = |_: &Entry<_>| finals += 1;

    // Warm-up: two seconds fill the 1 s history and every sensor slot.
    let (warm, rest) = samples.split_at(samples.len() / 5);
    for s in warm {
        engine.insert(s, None, &mut sink);
    }
    count_this_thread();
    let before = sizes();
    let mut late = 0;
    for s in rest {
        if let Insert::Processed { replayed, .. } = engine.insert(s, Some(s.header().t_ns), &mut sink) {
            late += (replayed > 0) as u64;
        }
    }
    let after = sizes();
    assert!(late > 50, "the measured stretch must include late samples (rewinds), had {late}");
    assert!(finals > 1500);
    assert_eq!(after, before, "allocations (size, count) while inserting {} samples", rest.len());
}

/// One test: the counters are the process's, summed over the counted threads, so
/// the parts must not run in parallel.
#[test]
fn steady_state_insertion_and_filter_steps_allocate_nothing() {
    // Each part on a fresh thread: counting starts after its own set-up.
    std::thread::spawn(|| linear("joseph")).join().unwrap();
    std::thread::spawn(|| linear("udu")).join().unwrap();
    std::thread::spawn(ins_in_the_udu_form).join().unwrap();
    std::thread::spawn(the_precision_study_steps).join().unwrap();
}

fn linear(form: &str) {
    let mut c = ScenarioConfig { seed: 2, duration_s: 10.0, ..Default::default() };
    c.imu.rate_hz = 1000.0;
    c.position.outlier_probability = 0.05;
    let samples: Vec<_> = Scenario::generate(&c).arrivals.into_iter().map(|a| a.sample).collect();
    let text = format!(
        "[model]\nkind = \"linear\"\naccel_noise_std = 0.3\n[filter]\nform = \"{form}\"\n\
             initial_state = [0,0,0,0,0,0]\ninitial_covariance_diagonal = [100,100,100,225,225,225]\n\
             [gating]\nprobability = 0.999\n"
    );
    let config = Config::parse(&text).unwrap();
    steady_state_allocates_nothing(LinearModel::from_config(&config).unwrap(), &config, &samples);
}

fn ins_in_the_udu_form() {
    let (scenario, _) = fusion_benches::precision::drives::ins(10.0, 0.5, 3);
    let samples: Vec<_> = scenario.arrivals.iter().map(|a| a.sample).collect();
    let text = fusion_benches::ins_config_text().replacen("[filter]\n", "[filter]\nform = \"udu\"\n", 1);
    let udu = Config::parse(&text).unwrap();
    assert_eq!(udu.filter.form, fusion_daemon::filter::Form::Udu);
    steady_state_allocates_nothing(InsModel::from_config(&udu).unwrap(), &udu, &samples);
}

fn the_precision_study_steps() {
    use fusion_benches::precision::{InsRun, LinearRun, StudyRun, drives, time_ordered};
    use fusion_daemon::filter::Form;
    let (lin_drive, lin) = drives::linear(5.0, 0.01, 4);
    let (ins_drive, ins) = drives::ins(5.0, 0.5, 4);
    let mut runs: Vec<(Box<dyn StudyRun>, Vec<Sample>)> = vec![
        (Box::new(LinearRun::<f32>::new(&lin, Form::Udu)), time_ordered(&lin_drive)),
        (Box::new(LinearRun::<f32>::new(&lin, Form::Joseph)), time_ordered(&lin_drive)),
        (Box::new(InsRun::<f32>::new(&ins, Form::Udu)), time_ordered(&ins_drive)),
        (Box::new(InsRun::<f64>::new(&ins, Form::Joseph)), time_ordered(&ins_drive)),
    ];
    for (run, samples) in &mut runs {
        count_this_thread();
        let before = sizes();
        for s in samples.iter() {
            run.step(s);
        }
        assert_eq!(sizes(), before, "allocations over {} steps", samples.len());
    }
}
