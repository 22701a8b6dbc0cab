//! The engine allocates nothing per sample in steady state, in order or late.
//!
//! The counting allocator of [`fusion_benches::alloc`] counts every allocation
//! made on this thread while samples are inserted after a warm-up.

use fusion_benches::alloc::{Counting, count_this_thread, sizes};
use fusion_client::sim::{ImuConfig, ImuOutput, Scenario, ScenarioConfig, Stop};
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
/// Returns the standstill updates the counted stretch fused.
fn steady_state_allocates_nothing<M: Steps>(model: M, config: &Config, samples: &[Sample]) -> u64 {
    let mut engine = Engine::new(model, EngineConfig::from_config(config));
    let mut finals = 0u64;
    let mut sink = |_: &Entry<_>| finals += 1;

    // Warm-up: two seconds fill the 1 s history and every sensor slot.
    let (warm, rest) = samples.split_at(samples.len() / 5);
    for s in warm {
        engine.insert(s, None, &mut sink);
    }
    let updates_before = engine.latest().map_or(0, |e| M::diagnostics(&e.state).standstill_updates);
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
    engine.latest().map_or(0, |e| M::diagnostics(&e.state).standstill_updates) - updates_before
}

/// One test: the counters are the process's, summed over the counted threads, so
/// the parts must not run in parallel.
#[test]
fn steady_state_insertion_and_filter_steps_allocate_nothing() {
    // Each part on a fresh thread: counting starts after its own set-up.
    std::thread::spawn(|| linear("joseph")).join().unwrap();
    std::thread::spawn(|| linear("udu")).join().unwrap();
    std::thread::spawn(ins_in_the_udu_form).join().unwrap();
    std::thread::spawn(ins_standing_still).join().unwrap();
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

/// A drive with a stop, `[model.standstill]` on: detection, the standstill
/// updates (with the yaw held) and the held attitude allocate nothing either.
fn ins_standing_still() {
    let mut c = ScenarioConfig {
        seed: 4,
        duration_s: 30.0,
        imu_output: ImuOutput::BodySpecificForce,
        stops: vec![Stop::new(8.0, 10.0)],
        ..Default::default()
    };
    c.imu =
        ImuConfig { accel_bias_std: 0.05, gyro_bias_std: 5e-4, ..ImuConfig::kalibr(200.0, 0.02, 0.001, 0.001, 1e-5) };
    let scenario = Scenario::generate(&c);
    let samples: Vec<_> = scenario.arrivals.iter().map(|a| a.sample).collect();
    let t0 = samples.iter().map(Sample::t_ns).min().unwrap();
    let truth = scenario.truth_at(t0);
    let (p, v, q) = (truth.pos_m, truth.vel_mps, truth.attitude.quaternion().coords);
    let x0 = [p.x, p.y, p.z, v.x, v.y, v.z, q[3], q[0], q[1], q[2], 0.0, 0.0, 0.0, 0.0, 0.0, 0.0];
    let list = |v: &[f64]| v.iter().map(|x| format!("{x:e}")).collect::<Vec<_>>().join(", ");
    let config = Config::parse(&format!(
        "[model]\nkind = \"ins\"\naccelerometer_noise_density = 0.02\ngyroscope_noise_density = 0.001\n\
         accelerometer_random_walk = 0.001\ngyroscope_random_walk = 1.0e-5\n[model.standstill]\n[filter]\n\
         initial_state = [{}]\n\
         initial_covariance_diagonal = [0.25,0.25,0.25, 0.09,0.09,0.09, 4e-4,4e-4,4e-4, 0.0025,0.0025,0.0025, 2.5e-7,2.5e-7,2.5e-7]\n\
         [gating]\nprobability = 0.9999\n",
        list(&x0)
    ))
    .unwrap();
    let updates = steady_state_allocates_nothing(InsModel::from_config(&config).unwrap(), &config, &samples);
    assert!(updates > 40, "the counted stretch stood still: {updates} standstill updates");
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
