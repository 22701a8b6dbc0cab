use fusion_shared::{KindVisitor, SampleKind};

use super::publish::{integer_words, integers_out_of_range, payload_is_finite};
use super::*;

/// What `payload_is_finite` relies on: every kind's payload is f64s right
/// after the header, but for the integer words it names; a NaN in any f64 is
/// seen, and the integer words are no f64 (every bit pattern of them passes
/// the float check).
#[test]
fn every_payload_value_is_checked() {
    struct Check;
    impl KindVisitor for Check {
        fn visit<T: WireSample>(&mut self) {
            let header = std::mem::size_of::<fusion_shared::SampleHeader>();
            assert_eq!((std::mem::size_of::<T>() - header) % 8, 0);
            let good = T::default();
            assert!(payload_is_finite(&good), "{:?}", T::KIND);
            for i in 0..(std::mem::size_of::<T>() - header) / 8 {
                let mut bad = good;
                if integer_words(T::KIND).contains(&i) {
                    // SAFETY: slot `i` of the payload, as in `payload_is_finite`.
                    unsafe { (&mut bad as *mut T).cast::<u8>().add(header + 8 * i).cast::<u64>().write_unaligned(!0) };
                    assert!(payload_is_finite(&bad), "{:?} integer slot {i}", T::KIND);
                    assert_ne!(format!("{bad:?}"), format!("{good:?}"), "{:?} slot {i}", T::KIND);
                    continue;
                }
                // SAFETY: slot `i` of the payload, as in `payload_is_finite`.
                unsafe {
                    (&mut bad as *mut T).cast::<u8>().add(header + 8 * i).cast::<f64>().write_unaligned(f64::NAN)
                };
                assert!(!payload_is_finite(&bad), "{:?} slot {i}", T::KIND);
                // And the slot is a real field: the sample changed.
                assert_ne!(format!("{bad:?}"), format!("{good:?}"), "{:?} slot {i}", T::KIND);
            }
        }
    }
    SampleKind::visit_all(&mut Check);
}

/// A geodetic fix's integers are checked as integers, each with its own
/// reason (reading them as an f64 had called −1 satellites a NaN).
#[test]
fn integers_are_checked_as_integers() {
    let fix = fusion_shared::GeodeticSample::default();
    assert!(payload_is_finite(&fix.with_quality(3, -1, 0.8, 1.2)));
    let why = integers_out_of_range(&fix.with_quality(3, -1, 0.8, 1.2)).unwrap();
    assert!(why.contains("-1 satellites"), "{why}");
    let why = integers_out_of_range(&fix.with_quality(99, 9, 0.8, 1.2)).unwrap();
    assert!(why.contains("fix type 99"), "{why}");
    assert_eq!(integers_out_of_range(&fix.with_quality(3, 9, 0.8, 1.2)), None);
    // A pose's reset counter is any u32.
    let pose = fusion_shared::PoseSample { reset_counter: u32::MAX, ..Default::default() };
    assert!(payload_is_finite(&pose) && integers_out_of_range(&pose).is_none());
}

#[test]
fn null_pointers_and_bad_arguments_are_errors() {
    let mut client = std::ptr::null_mut();
    // SAFETY: the arguments are null or valid.
    unsafe {
        assert_eq!(
            fusion_client_connect(std::ptr::null(), std::ptr::null(), &mut client),
            FusionStatus::FusionErrorNull
        );
        assert_eq!(
            fusion_client_connect(c"x".as_ptr(), std::ptr::null(), std::ptr::null_mut()),
            FusionStatus::FusionErrorNull
        );
        assert_eq!(
            fusion_client_connect(c"a/b".as_ptr(), std::ptr::null(), &mut client),
            FusionStatus::FusionErrorInvalidArgument
        );
        let message = CStr::from_ptr(fusion_last_error()).to_str().unwrap();
        assert!(message.contains("invalid namespace"), "{message}");
        assert!(client.is_null());
        let mut publisher = std::ptr::null_mut();
        assert_eq!(
            fusion_publisher_new(std::ptr::null(), FUSION_KIND_IMU, 0, &mut publisher),
            FusionStatus::FusionErrorNull
        );
        assert_eq!(
            fusion_publish_imu(std::ptr::null_mut(), std::ptr::null(), std::ptr::null_mut()),
            FusionStatus::FusionErrorNull
        );
        let mut snapshot = StateSnapshot::default();
        assert_eq!(fusion_state_latest(std::ptr::null_mut(), &mut snapshot), FusionStatus::FusionErrorNull);
        fusion_client_free(std::ptr::null_mut());
        fusion_publisher_free(std::ptr::null_mut());
        fusion_state_reader_free(std::ptr::null_mut());
    }
}

/// The C names and settings of the rejection codes are the Rust ones.
#[test]
fn rejection_names_and_settings_are_the_shared_ones() {
    use fusion_shared::snapshot::rejection;
    for code in 0..=rejection::COUNT as u32 + 1 {
        // SAFETY: static, NUL-terminated strings.
        let name = unsafe { CStr::from_ptr(fusion_rejection_name(code)) };
        assert_eq!(name.to_str().unwrap(), rejection::name(code), "code {code}");
        let setting = fusion_rejection_setting(code);
        // SAFETY: null or a static, NUL-terminated string.
        let setting = (!setting.is_null()).then(|| unsafe { CStr::from_ptr(setting) }.to_str().unwrap());
        assert_eq!(setting, rejection::setting(code), "code {code}");
    }
}
