//! The layout of each wire type as the C and Python mirrors give it: every
//! field's name, offset, scalar and count, and a line about the type, declared
//! beside the type (`wire_layout!`). The client's
//! generator writes the Python `ctypes` classes and the C API's kind constants
//! and publish functions from these declarations, so neither mirror is kept by
//! hand; a field left out fails [`WireLayout::check`].

/// The scalar of a field (an array's element).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Scalar {
    /// `f64`, C `double`.
    F64,
    /// `u64`, C `uint64_t`.
    U64,
    /// `u32`, C `uint32_t`.
    U32,
    /// `i32`, C `int32_t`.
    I32,
    /// Another wire type, by its Rust name (the header, a snapshot's rows).
    Struct(&'static str),
}

impl Scalar {
    /// Its `ctypes` spelling (a struct: its mirror class's name).
    pub fn ctypes(self) -> &'static str {
        match self {
            Scalar::F64 => "ctypes.c_double",
            Scalar::U64 => "ctypes.c_uint64",
            Scalar::U32 => "ctypes.c_uint32",
            Scalar::I32 => "ctypes.c_int32",
            Scalar::Struct(name) => name,
        }
    }
}

/// A type a wire field may have: a scalar or a (nested) array of one.
pub trait WireScalar {
    /// The scalar.
    const SCALAR: Scalar;
    /// How many scalars (1, or an array's elements, nested arrays flattened).
    const COUNT: usize;
}

macro_rules! scalars {
    ($($t:ty => $s:expr),* $(,)?) => {
        $(impl WireScalar for $t {
            const SCALAR: Scalar = $s;
            const COUNT: usize = 1;
        })*
    };
}
scalars!(f64 => Scalar::F64, u64 => Scalar::U64, u32 => Scalar::U32, i32 => Scalar::I32);

impl<T: WireScalar, const N: usize> WireScalar for [T; N] {
    const SCALAR: Scalar = T::SCALAR;
    const COUNT: usize = N * T::COUNT;
}

/// One field of a wire type.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct WireField {
    /// Its name, as in Rust, C and Python.
    pub name: &'static str,
    /// Its offset in the type, bytes.
    pub offset: usize,
    /// Its size, bytes.
    pub size: usize,
    /// Its scalar.
    pub scalar: Scalar,
    /// How many scalars (1: not an array).
    pub count: usize,
}

/// The field `name` at `offset` of `S`, of the type `get` reads
/// (`wire_layout!` calls it).
pub fn field<S, T: WireScalar>(name: &'static str, offset: usize, _get: fn(&S) -> &T) -> WireField {
    WireField { name, offset, size: std::mem::size_of::<T>(), scalar: T::SCALAR, count: T::COUNT }
}

/// What the mirrors need of a wire type.
pub trait WireLayout: Sized {
    /// What it is, one sentence (the Python class's docstring, the C publish
    /// function's comment).
    const DOC: &'static str;

    /// Its fields, in order.
    fn fields() -> Vec<WireField>;

    /// Whether the fields fill the type exactly, in order and without gaps:
    /// `Err` names the first one that does not (a field left out of the
    /// declaration, or one out of order).
    fn check() -> Result<(), String> {
        let mut at = 0;
        for f in Self::fields() {
            if f.offset != at {
                return Err(format!(
                    "{}: field {} at {} where {at} was expected",
                    std::any::type_name::<Self>(),
                    f.name,
                    f.offset
                ));
            }
            at += f.size;
        }
        if at == std::mem::size_of::<Self>() {
            Ok(())
        } else {
            Err(format!(
                "{}: its fields end at {at} of {} bytes",
                std::any::type_name::<Self>(),
                std::mem::size_of::<Self>()
            ))
        }
    }
}

/// Declares a wire type's layout ([`WireLayout`]) beside it, and makes it a
/// field type of other wire types ([`WireScalar`]):
///
/// ```text
/// wire_layout!(OdometrySample, "Forward speed from wheel odometry, m/s, with its variance.", {
///     header, speed_mps, var_m2ps2
/// });
/// ```
#[macro_export]
macro_rules! wire_layout {
    ($t:ident, $doc:expr, { $($f:ident),* $(,)? }) => {
        impl $crate::sample::layout::WireLayout for $t {
            const DOC: &'static str = $doc;
            fn fields() -> Vec<$crate::sample::layout::WireField> {
                vec![$($crate::sample::layout::field::<$t, _>(stringify!($f), std::mem::offset_of!($t, $f), |s: &$t| &s.$f)),*]
            }
        }

        impl $crate::sample::layout::WireScalar for $t {
            const SCALAR: $crate::sample::layout::Scalar = $crate::sample::layout::Scalar::Struct(stringify!($t));
            const COUNT: usize = 1;
        }
    };
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{KindVisitor, SampleHeader, SampleKind, WireSample};

    /// Every wire type's declared fields fill it exactly, in order.
    #[test]
    fn every_declared_layout_fills_its_type() {
        struct Check(usize);
        impl KindVisitor for Check {
            fn visit<T: WireSample>(&mut self) {
                T::check().unwrap();
                assert_eq!(T::fields()[0].scalar, Scalar::Struct("SampleHeader"), "a sample starts with its header");
                self.0 += 1;
            }
        }
        let mut check = Check(0);
        SampleKind::visit_all(&mut check);
        assert_eq!(check.0, SampleKind::COUNT);
        SampleHeader::check().unwrap();
        crate::snapshot::Counters::check().unwrap();
        crate::snapshot::SensorCounters::check().unwrap();
        crate::snapshot::StateSnapshot::check().unwrap();
        let x = crate::snapshot::StateSnapshot::fields().into_iter().find(|f| f.name == "x").unwrap();
        assert_eq!((x.scalar, x.count), (Scalar::F64, crate::snapshot::MAX_STATE));
    }

    /// A field left out of a declaration is found.
    #[test]
    fn a_missing_field_is_found() {
        #[derive(Default)]
        #[repr(C)]
        struct Two {
            a: f64,
            b: [u32; 2],
        }
        impl WireLayout for Two {
            const DOC: &'static str = "";
            fn fields() -> Vec<WireField> {
                vec![field::<Two, _>("a", std::mem::offset_of!(Two, a), |s: &Two| &s.a)]
            }
        }
        assert!(Two::check().unwrap_err().contains("end at 8 of 16"), "{:?}", Two::check());
        let _ = Two::default().b;
        let b = field::<Two, _>("b", std::mem::offset_of!(Two, b), |s: &Two| &s.b);
        assert_eq!((b.offset, b.size, b.scalar, b.count), (8, 8, Scalar::U32, 2));
    }
}
