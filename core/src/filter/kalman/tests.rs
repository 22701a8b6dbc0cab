use super::*;
use crate::filter::ChiSquareGate;
use nalgebra::{Matrix1, Matrix1x2, Matrix2, Vector1, Vector2};

#[test]
fn all_finite_finds_every_non_finite_entry() {
    let mut m = SMatrix::<f64, 5, 3>::from_fn(|i, j| (i as f64 - 2.0) * 1e300 * (j as f64 + 0.5));
    m[(4, 2)] = -f64::MAX;
    assert!(all_finite(&m));
    for bad in [f64::NAN, f64::INFINITY, f64::NEG_INFINITY] {
        for k in 0..15 {
            let mut b = m;
            b.as_mut_slice()[k] = bad;
            assert!(!all_finite(&b), "{bad} at {k}");
        }
    }
}

fn hand_filter() -> KalmanFilter<f64, 2> {
    KalmanFilter::new(Vector2::new(1.0, 2.0), Matrix2::new(4.0, 1.0, 1.0, 2.0)).unwrap()
}

#[test]
fn joseph_update_matches_hand_computed_values() {
    // x = [1, 2], P = [[4, 1], [1, 2]], z = 3, H = [1 0], R = 1.
    // y = 2, S = 5, K = [4/5, 1/5], x⁺ = [2.6, 2.4],
    // P⁺ = (I−KH) P (I−KH)ᵀ + K R Kᵀ = [[0.8, 0.2], [0.2, 1.8]], NIS = 4/5.
    let mut kf = hand_filter();
    let d =
        kf.update(&Vector1::new(3.0), &Matrix1x2::new(1.0, 0.0), &Matrix1::new(1.0), UpdateOptions::default()).unwrap();
    assert_eq!(d.decision, UpdateDecision::Accepted);
    let close = |a: f64, b: f64| (a - b).abs() < 1e-14;
    assert!(close(d.residual[0], 2.0) && close(d.S[(0, 0)], 5.0));
    assert!(close(d.K[0], 0.8) && close(d.K[1], 0.2));
    assert!(close(kf.x()[0], 2.6) && close(kf.x()[1], 2.4));
    let P = kf.P();
    assert!(close(P[(0, 0)], 0.8) && close(P[(0, 1)], 0.2) && close(P[(1, 0)], 0.2) && close(P[(1, 1)], 1.8));
    assert!(close(d.nis, 0.8));
    let ll = -0.5 * (0.8 + 5f64.ln() + (2.0 * std::f64::consts::PI).ln());
    assert!(close(d.log_likelihood().unwrap(), ll));
    assert!(close(d.dx[0], 1.6) && close(d.dx[1], 0.4));
    // Σdx = K S Kᵀ = 5 [[.64, .16], [.16, .04]].
    let sdx = d.sigma_dx();
    assert!(close(sdx[(0, 0)], 3.2) && close(sdx[(0, 1)], 0.8) && close(sdx[(1, 1)], 0.2));
}

#[test]
fn small_cholesky_solves_match_the_explicit_inverse() {
    let S = nalgebra::Matrix3::new(2.0, 0.6, -0.3, 0.6, 1.5, 0.2, -0.3, 0.2, 0.9);
    let B = SMatrix::<f64, 5, 3>::from_fn(|i, j| (i as f64 - 1.7) * (j as f64 + 0.3) + 0.1 * (i * j) as f64);
    let y = nalgebra::Vector3::new(0.7, -1.1, 0.4);
    let c = SmallCholesky::new(S).unwrap();
    let Si = S.try_inverse().unwrap();
    assert!((c.gain(&B) - B * Si).amax() < 1e-13);
    let w = c.whiten(&y);
    assert!((w.dot(&w) - (y.transpose() * Si * y)[0]).abs() < 1e-13);
    assert!(SmallCholesky::new(nalgebra::Matrix2::new(1.0, 2.0, 2.0, 1.0)).is_none());
}

#[test]
fn joseph_form_stays_psd_with_a_suboptimal_gain() {
    // With an exactly zero R the optimal update makes P⁺ singular; the Joseph
    // form must still give a symmetric PSD result, never a negative variance.
    let mut kf = hand_filter();
    kf.update(&Vector1::new(3.0), &Matrix1x2::new(1.0, 0.0), &Matrix1::new(1e-300), UpdateOptions::default()).unwrap();
    let eig = kf.P().symmetric_eigenvalues();
    assert!(eig.iter().all(|e| *e >= -1e-12), "{eig}");
}

#[test]
fn predict_with_input_and_mapped_noise() {
    // Constant velocity, dt = 0.5: F = [[1, .5], [0, 1]], G = [.125, .5], q = 4.
    let mut kf = hand_filter();
    let F = Matrix2::new(1.0, 0.5, 0.0, 1.0);
    let G = nalgebra::Matrix2x1::new(0.125, 0.5);
    let Q = map_process_noise(&G, &Matrix1::new(4.0));
    kf.predict_with_input(&F, &(G * 2.0), &Q).unwrap();
    // x = F x + G a = [1 + 1 + .25, 2 + 1] ; P = F P Fᵀ + G q Gᵀ.
    assert_eq!(*kf.x(), Vector2::new(2.25, 3.0));
    let P = F * Matrix2::new(4.0, 1.0, 1.0, 2.0) * F.transpose() + G * 4.0 * G.transpose();
    assert!((kf.P() - P).amax() < 1e-15);
}

#[test]
fn ekf_predict_uses_the_model_jacobian() {
    let mut kf = hand_filter();
    // f(x) = [x0², x1], F = [[2 x0, 0], [0, 1]]
    kf.predict_ekf(|x| (Vector2::new(x[0] * x[0], x[1]), Matrix2::new(2.0 * x[0], 0.0, 0.0, 1.0)), &Matrix2::zeros())
        .unwrap();
    assert_eq!(*kf.x(), Vector2::new(1.0, 2.0));
    assert_eq!(kf.P()[(0, 0)], 16.0);
    assert_eq!(kf.P()[(0, 1)], 2.0);
}

#[test]
fn indefinite_innovation_is_refused_and_state_kept() {
    let mut kf = hand_filter();
    let before = kf;
    let err = kf
        .update(&Vector1::new(3.0), &Matrix1x2::new(1.0, 0.0), &Matrix1::new(-10.0), UpdateOptions::default())
        .unwrap_err();
    assert_eq!(err, FilterError::InnovationNotPositiveDefinite);
    assert_eq!(kf, before);
}

#[test]
fn non_finite_inputs_never_enter_the_state() {
    let mut kf = hand_filter();
    let before = kf;
    let H = Matrix1x2::new(1.0, 0.0);
    assert!(kf.update(&Vector1::new(f64::NAN), &H, &Matrix1::new(1.0), UpdateOptions::default()).is_err());
    assert!(kf.update(&Vector1::new(1.0), &H, &Matrix1::new(f64::INFINITY), UpdateOptions::default()).is_err());
    assert!(kf.predict(&Matrix2::new(1e300, 0.0, 0.0, 1.0), &Matrix2::zeros()).is_err());
    assert!(kf.set_state(Vector2::new(f64::NAN, 0.0), Matrix2::identity()).is_err());
    assert_eq!(kf, before);
    assert!(KalmanFilter::new(Vector2::new(0.0, 0.0), Matrix2::new(1.0, 2.0, 2.0, 1.0)).is_err());
}

#[test]
fn gated_measurement_leaves_the_state_untouched() {
    let gate = ChiSquareGate::new(0.99).unwrap();
    let mut kf = hand_filter();
    let before = kf;
    let opts = UpdateOptions { gate: Some(&gate), fault_detector: None, consider: None };
    // y = 99, S = 5: NIS = 1960 ≫ 6.63.
    let d = kf.update(&Vector1::new(100.0), &Matrix1x2::new(1.0, 0.0), &Matrix1::new(1.0), opts).unwrap();
    assert_eq!(d.decision, UpdateDecision::Gated);
    assert!((d.gate_threshold.unwrap() - 6.634896601021214).abs() < 1e-9);
    assert_eq!(kf, before);
}

struct DropSecond;
impl FaultDetector<f64, 2, 2> for DropSecond {
    fn inspect(&mut self, m: &mut MeasurementView<f64, 2, 2>) -> FaultDecision {
        m.drop_component(1);
        FaultDecision::Modified
    }
}

#[test]
fn fault_hook_can_drop_a_component() {
    // Measuring both states with component 1 dropped equals measuring state 0 only.
    let mut a = hand_filter();
    let mut b = hand_filter();
    let mut hook = DropSecond;
    let d = a
        .update(
            &Vector2::new(3.0, 1000.0),
            &Matrix2::identity(),
            &Matrix2::new(1.0, 0.3, 0.3, 1.0),
            UpdateOptions { gate: None, fault_detector: Some(&mut hook), consider: None },
        )
        .unwrap();
    b.update(&Vector1::new(3.0), &Matrix1x2::new(1.0, 0.0), &Matrix1::new(1.0), UpdateOptions::default()).unwrap();
    assert_eq!(d.dims, 1);
    assert!((a.x() - b.x()).amax() < 1e-12 && (a.P() - b.P()).amax() < 1e-12);
    assert!((d.nis - 0.8).abs() < 1e-12);
}

#[test]
fn fault_hook_reweighting_and_rejection() {
    struct Inflate(f64);
    impl FaultDetector<f64, 2, 1> for Inflate {
        fn inspect(&mut self, m: &mut MeasurementView<f64, 2, 1>) -> FaultDecision {
            if self.0 == 0.0 {
                return FaultDecision::Reject;
            }
            m.reweight_component(0, self.0);
            FaultDecision::Modified
        }
    }
    let H = Matrix1x2::new(1.0, 0.0);
    let mut a = hand_filter();
    let mut b = hand_filter();
    let mut hook = Inflate(9.0);
    a.update(
        &Vector1::new(3.0),
        &H,
        &Matrix1::new(1.0),
        UpdateOptions { gate: None, fault_detector: Some(&mut hook), consider: None },
    )
    .unwrap();
    b.update(&Vector1::new(3.0), &H, &Matrix1::new(9.0), UpdateOptions::default()).unwrap();
    assert!((a.x() - b.x()).amax() < 1e-12 && (a.P() - b.P()).amax() < 1e-12);

    let mut c = hand_filter();
    let before = c;
    let mut reject = Inflate(0.0);
    let d = c
        .update(
            &Vector1::new(3.0),
            &H,
            &Matrix1::new(1.0),
            UpdateOptions { gate: None, fault_detector: Some(&mut reject), consider: None },
        )
        .unwrap();
    assert_eq!(d.decision, UpdateDecision::RejectedByHook);
    assert_eq!(c, before);
}

#[test]
fn f32_filter_matches_f64() {
    let mut a = KalmanFilter::<f32, 2>::new(Vector2::new(1.0, 2.0), Matrix2::new(4.0, 1.0, 1.0, 2.0)).unwrap();
    a.update(&Vector1::new(3.0), &Matrix1x2::new(1.0, 0.0), &Matrix1::new(1.0), UpdateOptions::default()).unwrap();
    assert!((a.x()[0] - 2.6).abs() < 1e-6 && (a.P()[(1, 1)] - 1.8).abs() < 1e-6);
}

/// The same filter in both forms, at a state with correlations.
fn both_forms() -> (KalmanFilter<f64, 3>, KalmanFilter<f64, 3>) {
    let P = nalgebra::Matrix3::new(4.0, 1.0, -0.5, 1.0, 2.0, 0.3, -0.5, 0.3, 1.5);
    let j = KalmanFilter::new(nalgebra::Vector3::new(1.0, 2.0, -1.0), P).unwrap();
    (j, j.with_form(Form::Udu).unwrap())
}

fn assert_same(j: &KalmanFilter<f64, 3>, u: &KalmanFilter<f64, 3>) {
    assert_eq!(u.form(), Form::Udu);
    assert!((j.x() - u.x()).amax() < 1e-13, "x {} {}", j.x(), u.x());
    assert!((j.P() - u.P()).amax() < 1e-13, "P {} {}", j.P(), u.P());
    let f = u.factors().unwrap();
    assert!((0..3).all(|i| f[(i, i)] > 0.0 && (0..i).all(|k| f[(i, k)] == 0.0)));
}

#[test]
fn udu_form_full_r_is_decorrelated_and_equals_joseph() {
    let (mut j, mut u) = both_forms();
    let z = Vector2::new(1.5, 0.4);
    let H = nalgebra::Matrix2x3::new(1.0, 0.0, 0.5, 0.0, 1.0, -1.0);
    let R = Matrix2::new(0.5, 0.2, 0.2, 0.3);
    let dj = j.update(&z, &H, &R, UpdateOptions::default()).unwrap();
    let du = u.update(&z, &H, &R, UpdateOptions::default()).unwrap();
    assert_same(&j, &u);
    assert!((dj.nis - du.nis).abs() < 1e-13 && (dj.K - du.K).amax() < 1e-13);
    // Predict with a rank-deficient Q (one noise input for three states).
    let F = nalgebra::Matrix3::new(1.0, 0.1, 0.0, 0.0, 1.0, 0.1, 0.0, 0.0, 1.0);
    let g = nalgebra::Vector3::new(0.005, 0.1, 1.0);
    let Q = g * g.transpose() * 0.2;
    j.predict(&F, &Q).unwrap();
    u.predict(&F, &Q).unwrap();
    assert_same(&j, &u);
}

#[test]
fn udu_form_gate_hook_and_refusals_as_joseph() {
    let gate = ChiSquareGate::new(0.99).unwrap();
    let H = nalgebra::Matrix2x3::new(1.0, 0.0, 0.0, 0.0, 1.0, 0.0);
    let R = Matrix2::new(1.0, 0.3, 0.3, 1.0);
    // Gated: nothing changes in either form.
    let (_, mut u) = both_forms();
    let before = u;
    let d = u.update(
        &Vector2::new(100.0, 2.0),
        &H,
        &R,
        UpdateOptions { gate: Some(&gate), fault_detector: None, consider: None },
    );
    assert_eq!(d.unwrap().decision, UpdateDecision::Gated);
    assert_eq!(u, before);
    // A hook that drops component 1: the same result as in the Joseph form.
    let (mut j, mut u) = both_forms();
    let mut hook = DropSecond3;
    j.update(
        &Vector2::new(3.0, 1000.0),
        &H,
        &R,
        UpdateOptions { gate: None, fault_detector: Some(&mut hook), consider: None },
    )
    .unwrap();
    u.update(
        &Vector2::new(3.0, 1000.0),
        &H,
        &R,
        UpdateOptions { gate: None, fault_detector: Some(&mut hook), consider: None },
    )
    .unwrap();
    assert_same(&j, &u);
    // An indefinite S, a NaN, a non-PD R with an indefinite S: refused, state kept.
    let before = u;
    let bad_R = Matrix2::new(-10.0, 0.0, 0.0, 1.0);
    assert_eq!(
        u.update(&Vector2::new(1.0, 1.0), &H, &bad_R, UpdateOptions::default()).unwrap_err(),
        FilterError::InnovationNotPositiveDefinite
    );
    assert!(u.update(&Vector2::new(f64::NAN, 1.0), &H, &R, UpdateOptions::default()).is_err());
    assert!(u.predict(&nalgebra::Matrix3::identity(), &nalgebra::Matrix3::from_diagonal_element(-1.0)).is_err());
    assert!(u.set_state(*u.x(), indefinite3()).is_err());
    assert_eq!(u, before);
}

#[test]
fn udu_form_selection_update_and_resets_as_joseph() {
    let (mut j, mut u) = both_forms();
    let z = Vector2::new(0.3, 2.5);
    let R = Matrix2::new(0.2, 0.05, 0.05, 0.4);
    let (dj, nj) = j.update_selection_lean(&z, &Vector2::new(2.0, -1.0), 1, &R, None).unwrap();
    let (du, nu) = u.update_selection_lean(&z, &Vector2::new(2.0, -1.0), 1, &R, None).unwrap();
    assert_eq!(dj, du);
    assert!((nj - nu).abs() < 1e-13);
    assert_same(&j, &u);
    let G = nalgebra::Matrix3::new(1.0, 0.0, 0.0, 0.0, 1.0, -0.01, 0.0, 0.01, 1.0);
    j.reset_transform(|P| *P = G * *P * G.transpose(), || unreachable!("the Joseph form uses its own transform"));
    u.reset_transform(|_| unreachable!("the UDU form transforms the factors"), || G);
    assert_same(&j, &u);
    j.reset_error(|P| P[(2, 2)] = P[(2, 2)].max(3.0));
    u.reset_error(|P| P[(2, 2)] = P[(2, 2)].max(3.0));
    assert_same(&j, &u);
    assert_eq!(u.variance(2), 3.0);
}

struct DropSecond3;
impl FaultDetector<f64, 3, 2> for DropSecond3 {
    fn inspect(&mut self, m: &mut MeasurementView<f64, 3, 2>) -> FaultDecision {
        m.drop_component(1);
        FaultDecision::Modified
    }
}

fn indefinite3() -> nalgebra::Matrix3<f64> {
    nalgebra::Matrix3::new(1.0, 2.0, 0.0, 2.0, 1.0, 0.0, 0.0, 0.0, 1.0)
}

/// A consider direction: the update leaves the state and its variance along it
/// as they were, its covariance is the Joseph form's for the projected gain,
/// and both forms agree.
#[test]
fn a_consider_direction_is_not_moved_and_the_covariance_is_exact() {
    let (mut j, mut u) = both_forms();
    let (x0, P0) = (*j.x(), j.P());
    let c = nalgebra::Vector3::new(0.0, 0.6, 0.8);
    let z = Vector2::new(1.5, 0.4);
    let H = nalgebra::Matrix2x3::new(1.0, 0.0, 0.5, 0.0, 1.0, -1.0);
    let R = Matrix2::new(0.5, 0.2, 0.2, 0.3);
    let options = || UpdateOptions { consider: Some(c), ..UpdateOptions::default() };
    let d = j.update(&z, &H, &R, options()).unwrap();
    u.update(&z, &H, &R, options()).unwrap();
    assert_same(&j, &u);
    assert!((c.dot(j.x()) - c.dot(&x0)).abs() < 1e-14, "moved along c");
    assert!((c.dot(&(j.P() * c)) - c.dot(&(P0 * c))).abs() < 1e-13, "variance along c changed");
    let S = H * P0 * H.transpose() + R;
    let K = P0 * H.transpose() * S.try_inverse().unwrap();
    let K = K - c * (c.transpose() * K);
    assert!((d.K - K).amax() < 1e-13);
    let I_KH = nalgebra::Matrix3::identity() - K * H;
    let P = I_KH * P0 * I_KH.transpose() + K * R * K.transpose();
    assert!((j.P() - P).amax() < 1e-13, "{} against {P}", j.P());
    assert!((j.x() - (x0 + K * (z - H * x0))).amax() < 1e-13);
    // The optimal update does move along c.
    let (mut o, _) = both_forms();
    o.update(&z, &H, &R, UpdateOptions::default()).unwrap();
    assert!((c.dot(o.x()) - c.dot(&x0)).abs() > 0.1);
}
