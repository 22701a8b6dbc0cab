//! Publishing samples from C: one entry point for every kind, `fusion_publish`
//! (the kind, a pointer to its wire struct and the struct's size, all
//! checked), and the per-kind `fusion_publish_<kind>` generated beside it
//! (`kinds.rs`). Each checks its pointers, the publisher's kind and that every
//! value is finite.

use std::sync::OnceLock;

use fusion_shared::sample::layout::Scalar;
use fusion_shared::{KindFn, SampleKind, WireSample};

use super::{Failure, FusionPublisher, FusionStatus, guard, null};
use crate::SamplePublisher;

/// The words (8 bytes each, after the header) of a payload that hold integers
/// rather than an `f64` (geodetic's fix type and satellites, pose's reset
/// counter), from the kind's declared layout; computed once per kind.
pub(super) fn integer_words(kind: SampleKind) -> &'static [usize] {
    struct Integers;
    impl KindFn for Integers {
        type Output = Vec<usize>;
        fn call<T: WireSample>(self) -> Vec<usize> {
            let header = std::mem::size_of::<fusion_shared::SampleHeader>();
            let fields = <T as fusion_shared::sample::layout::WireLayout>::fields();
            let integers = fields.iter().filter(|f| !matches!(f.scalar, Scalar::F64 | Scalar::Struct(_)));
            let mut words: Vec<usize> = integers.map(|f| (f.offset - header) / 8).collect();
            words.dedup();
            words
        }
    }
    static WORDS: [OnceLock<Vec<usize>>; SampleKind::COUNT] = [const { OnceLock::new() }; SampleKind::COUNT];
    WORDS[kind.index()].get_or_init(|| kind.with_wire_type(Integers))
}

/// Every `f64` of the payload of `sample` (the words after the header that
/// [`integer_words`] does not name) is finite.
pub(super) fn payload_is_finite<T: WireSample>(sample: &T) -> bool {
    let header = std::mem::size_of::<fusion_shared::SampleHeader>();
    let values = (std::mem::size_of::<T>() - header) / 8;
    let base = (sample as *const T).cast::<u8>();
    let integers = integer_words(T::KIND);
    (0..values).filter(|i| !integers.contains(i)).all(|i| {
        // SAFETY: within `sample`, which is `#[repr(C)]` with its f64 fields
        // right after the header (8-byte aligned); read unaligned all the same.
        let v = unsafe { base.add(header + 8 * i).cast::<f64>().read_unaligned() };
        v.is_finite()
    })
}

/// Why the integers of `sample` are out of their range, if they are.
pub(super) fn integers_out_of_range<T: WireSample>(sample: &T) -> Option<String> {
    use fusion_shared::{Sample, fix};
    match sample.into_sample() {
        Sample::Geodetic(g) if g.fix_type as usize >= fix::COUNT => Some(format!(
            "geodetic sample with fix type {}, which is no fix type code (0 to {})",
            g.fix_type,
            fix::COUNT - 1
        )),
        Sample::Geodetic(g) if !(0..=fix::MAX_SATELLITES).contains(&g.satellites) => Some(format!(
            "geodetic sample with {} satellites (0 to {}; 0: not reported)",
            g.satellites,
            fix::MAX_SATELLITES
        )),
        _ => None,
    }
}

/// Publishes `sample` as this publisher's next: the header's `t_ns` is the
/// caller's; sensor id, sequence number, kind and send time are stamped.
///
/// # Safety
/// Pointers null or valid.
pub(super) unsafe fn publish<T: WireSample>(
    publisher: *mut FusionPublisher,
    sample: *const T,
    reached: *mut usize,
) -> FusionStatus {
    guard(|| {
        // SAFETY: null or a live publisher / a sample, by the caller's contract.
        let p = unsafe { publisher.as_mut() }.ok_or_else(|| null("publisher"))?;
        let sample = *unsafe { sample.as_ref() }.ok_or_else(|| null("sample"))?;
        let kind = p.kind;
        let typed = p.publisher.downcast_mut::<SamplePublisher<T>>().ok_or_else(|| {
            let name = fusion_shared::SampleKind::from_code(kind).map_or("unknown", |k| k.name());
            Failure(
                FusionStatus::FusionErrorWrongKind,
                format!("a {} sample given to a {name} publisher", T::KIND.name()),
            )
        })?;
        if !payload_is_finite(&sample) {
            return Err(Failure(
                FusionStatus::FusionErrorInvalidArgument,
                format!("{} sample with a NaN or infinite value", T::KIND.name()),
            ));
        }
        if let Some(why) = integers_out_of_range(&sample) {
            return Err(Failure(FusionStatus::FusionErrorInvalidArgument, why));
        }
        let n = typed.publish_next(sample)?;
        // SAFETY: null or writable, by the caller's contract.
        if let Some(r) = unsafe { reached.as_mut() } {
            *r = n;
        }
        Ok(FusionStatus::FusionOk)
    })
}

/// Publishes the sample at `sample`, of kind `kind` (`FUSION_KIND_*`): its
/// wire struct (`FusionImuSample` for `FUSION_KIND_IMU`, …), `size` bytes
/// (`sizeof` of that struct). The kind must be one (`1..=FUSION_KIND_COUNT`),
/// the size its struct's and the publisher's kind the same
/// (`FUSION_ERROR_INVALID_ARGUMENT`, `FUSION_ERROR_WRONG_KIND`); then it is
/// published as by `fusion_publish_<kind>`. `*reached` (if not NULL) is the
/// number of readers it reached: 0 when no fusiond runs.
///
/// # Safety
/// `publisher` null or live; `sample` null or valid for `size` bytes;
/// `reached` null or writable.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn fusion_publish(
    publisher: *mut FusionPublisher,
    kind: u32,
    sample: *const std::ffi::c_void,
    size: usize,
    reached: *mut usize,
) -> FusionStatus {
    struct Typed {
        publisher: *mut FusionPublisher,
        sample: *const std::ffi::c_void,
        size: usize,
        reached: *mut usize,
    }
    impl KindFn for Typed {
        type Output = FusionStatus;
        fn call<T: WireSample>(self) -> FusionStatus {
            if self.size != std::mem::size_of::<T>() {
                let why = format!(
                    "a {} sample is {} bytes (sizeof(Fusion{})), not {}",
                    T::KIND.name(),
                    std::mem::size_of::<T>(),
                    std::any::type_name::<T>().rsplit("::").next().unwrap_or(""),
                    self.size
                );
                return guard(|| Err(Failure(FusionStatus::FusionErrorInvalidArgument, why)));
            }
            // SAFETY: the caller's contract, the size checked to be the type's.
            unsafe { publish(self.publisher, self.sample.cast::<T>(), self.reached) }
        }
    }
    match SampleKind::from_code(kind) {
        Some(k) => k.with_wire_type(Typed { publisher, sample, size, reached }),
        None => guard(|| {
            Err(Failure(
                FusionStatus::FusionErrorInvalidArgument,
                format!("kind {kind} is no sample kind (1 to FUSION_KIND_COUNT, {})", SampleKind::COUNT),
            ))
        }),
    }
}
