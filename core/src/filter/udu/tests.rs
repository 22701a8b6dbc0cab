use super::*;
use crate::filter::{KalmanFilter, UpdateOptions};
use nalgebra::{Matrix1x3, Matrix2, Matrix3, SMatrix, SVector, Vector1, Vector3};
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// Relative difference of two matrices, against the larger entry of `b`.
fn rel<const R: usize, const C: usize>(a: &SMatrix<f64, R, C>, b: &SMatrix<f64, R, C>) -> f64 {
    (a - b).amax() / b.amax().max(f64::MIN_POSITIVE)
}

/// Checks the invariants of packed factors: finite, `D > 0` (nothing is zero in
/// these problems), and nothing below the diagonal.
fn assert_valid<const N: usize>(ud: &SMatrix<f64, N, N>) {
    for j in 0..N {
        assert!(ud[(j, j)] > 0.0, "D_{j} = {}", ud[(j, j)]);
        for i in 0..N {
            assert!(ud[(i, j)].is_finite());
            if i > j {
                assert_eq!(ud[(i, j)], 0.0, "below the diagonal at ({i}, {j})");
            }
        }
    }
}

fn random_spd<const N: usize>(rng: &mut ChaCha8Rng, scale_spread: f64) -> SMatrix<f64, N, N> {
    let A = SMatrix::<f64, N, N>::from_fn(|_, _| rng.random_range(-1.0..1.0));
    let s = SMatrix::<f64, N, N>::from_diagonal(&SVector::from_fn(|i, _| {
        10f64.powf(scale_spread * (i as f64 / N as f64 - 0.5))
    }));
    let P = s * (A * A.transpose() + SMatrix::identity() * 0.1) * s;
    (P + P.transpose()) * 0.5
}

#[test]
fn factorize_and_compose_a_hand_computed_case() {
    // P = [[4, 2], [2, 2]]: D_1 = 2, U_01 = 2/2 = 1, D_0 = 4 − 1·2 = 2.
    let P = Matrix2::new(4.0, 2.0, 2.0, 2.0);
    let ud = factorize(&P, 0.0).unwrap();
    assert_eq!(ud, Matrix2::new(2.0, 1.0, 0.0, 2.0));
    assert_eq!(compose(&ud), P);
    assert_eq!(variance(&ud, 0), 4.0);
    assert!(factorize(&Matrix2::new(1.0, 2.0, 2.0, 1.0), 0.0).is_none(), "indefinite");
    assert!(factorize(&Matrix2::new(1.0, 1.0, 1.0, 1.0), 0.0).is_none(), "singular, PD asked");
    // Singular but PSD with a tolerance: D_0 = 0 and U's column 0 … of a 2×2 is empty.
    let ud = factorize(&Matrix2::new(1.0, 1.0, 1.0, 1.0), 1e-12).unwrap();
    assert_eq!(ud, Matrix2::new(0.0, 1.0, 0.0, 1.0));
}

#[test]
fn bierman_a_hand_computed_case() {
    // x = [1, 2], P = [[4, 1], [1, 2]] (U_01 = 1/2, D = [3.5, 2]), z = 3, h = [1 0],
    // r = 1: as the Joseph test of the dense filter, x⁺ = [2.6, 2.4],
    // P⁺ = [[0.8, 0.2], [0.2, 1.8]], α = S = 5.
    let mut ud = factorize(&Matrix2::new(4.0, 1.0, 1.0, 2.0), 0.0).unwrap();
    assert_eq!(ud, Matrix2::new(3.5, 0.5, 0.0, 2.0));
    let mut x = SVector::<f64, 2>::new(1.0, 2.0);
    let alpha = bierman(&mut ud, &mut x, &[1.0, 0.0], 1.0, 2.0);
    assert_eq!(alpha, 5.0);
    assert!((x - SVector::<f64, 2>::new(2.6, 2.4)).amax() < 1e-15);
    assert!((compose(&ud) - Matrix2::new(0.8, 0.2, 0.2, 1.8)).amax() < 1e-15);
}

#[test]
fn thornton_a_hand_computed_case() {
    // P = I, F = [[1, 1], [0, 1]], Q = diag(0, 1) (G = I, D_q = [0, 1]):
    // F P Fᵀ + Q = [[2, 1], [1, 2]]: D_1 = 2, U_01 = 1/2, D_0 = 2 − ¼·2 = 1.5.
    let mut ud = Matrix2::identity();
    thornton(&mut ud, &Matrix2::new(1.0, 1.0, 0.0, 1.0), &Matrix2::identity(), &SVector::<f64, 2>::new(0.0, 1.0));
    assert_eq!(ud, Matrix2::new(1.5, 0.5, 0.0, 2.0));
    assert_eq!(compose(&ud), Matrix2::new(2.0, 1.0, 1.0, 2.0));
}

#[test]
fn random_problems_match_the_dense_forms() {
    let mut rng = ChaCha8Rng::seed_from_u64(16);
    for trial in 0..200 {
        let P = random_spd::<6>(&mut rng, 6.0);
        let ud = factorize(&P, 0.0).unwrap();
        assert_valid(&ud);
        assert!(rel(&compose(&ud), &P) < 1e-13, "trial {trial}: factorize");

        // Time update against F P Fᵀ + G Dq Gᵀ.
        let F = SMatrix::<f64, 6, 6>::from_fn(|i, j| if i == j { 1.0 } else { rng.random_range(-0.3..0.3) });
        let G = SMatrix::<f64, 6, 3>::from_fn(|_, _| rng.random_range(-1.0..1.0));
        let dq = Vector3::new(rng.random_range(0.0..1.0), 0.0, rng.random_range(0.0..1e-3));
        let mut t = ud;
        thornton(&mut t, &F, &G, &dq);
        assert_valid(&t);
        let dense = F * P * F.transpose() + G * Matrix3::from_diagonal(&dq) * G.transpose();
        assert!(rel(&compose(&t), &dense) < 1e-12, "trial {trial}: thornton {}", rel(&compose(&t), &dense));

        // Scalar updates against the Joseph form of the dense filter.
        let h: [f64; 6] = std::array::from_fn(|_| rng.random_range(-1.0..1.0));
        let r = 10f64.powf(rng.random_range(-4.0..1.0));
        let x0 = SVector::<f64, 6>::from_fn(|_, _| rng.random_range(-5.0..5.0));
        let z = rng.random_range(-5.0..5.0);
        let mut kf = KalmanFilter::new(x0, P).unwrap();
        let H = SMatrix::<f64, 1, 6>::from_row_slice(&h);
        let d = kf.update(&Vector1::new(z), &H, &Vector1::new(r), UpdateOptions::default()).unwrap();
        let (mut u, mut x) = (ud, x0);
        let alpha = bierman(&mut u, &mut x, &h, r, z - (H * x0)[0]);
        assert_valid(&u);
        assert!((alpha - d.S[(0, 0)]).abs() < 1e-12 * alpha, "trial {trial}: α");
        assert!(rel(&x, kf.x()) < 1e-12, "trial {trial}: x");
        assert!(rel(&compose(&u), &kf.P()) < 1e-11, "trial {trial}: P {}", rel(&compose(&u), &kf.P()));
    }
}

#[test]
fn factors_stay_unit_upper_triangular_and_positive_over_many_steps() {
    // A constant-velocity chain with very accurate position fixes: the factors
    // must keep D > 0 and nothing below the diagonal at every step.
    let mut ud = factorize(&Matrix2::new(100.0, 0.0, 0.0, 10.0), 0.0).unwrap();
    let mut x = SVector::<f64, 2>::zeros();
    let F = Matrix2::new(1.0, 0.01, 0.0, 1.0);
    let G = SMatrix::<f64, 2, 1>::new(0.5e-4, 0.01);
    for k in 0..10_000 {
        thornton(&mut ud, &F, &G, &SVector::<f64, 1>::new(0.09));
        assert_valid(&ud);
        if k % 10 == 0 {
            bierman(&mut ud, &mut x, &[1.0, 0.0], 1e-10, 0.0);
            assert_valid(&ud);
        }
    }
}

#[test]
fn transform_is_a_noise_free_time_update() {
    let mut rng = ChaCha8Rng::seed_from_u64(3);
    let P = random_spd::<3>(&mut rng, 2.0);
    let G = Matrix3::new(1.0, -0.02, 0.01, 0.02, 1.0, -0.03, -0.01, 0.03, 1.0);
    let mut ud = factorize(&P, 0.0).unwrap();
    transform(&mut ud, &G);
    assert!(rel(&compose(&ud), &(G * P * G.transpose())) < 1e-14);
}

#[test]
fn times_transpose_is_p_h_transposed() {
    let mut rng = ChaCha8Rng::seed_from_u64(4);
    let P = random_spd::<3>(&mut rng, 3.0);
    let H = Matrix1x3::new(0.3, -1.0, 2.0);
    let ud = factorize(&P, 0.0).unwrap();
    assert!(rel(&times_transpose(&ud, &H), &(P * H.transpose())) < 1e-14);
}
