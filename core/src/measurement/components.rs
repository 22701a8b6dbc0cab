//! `fuse = [...]`: the components of a six-component sample (a twist, a pose)
//! a sensor fuses, by name.

use std::marker::PhantomData;

use serde::Deserialize;

/// The names of a kind's six components, in its sample's order.
pub trait ComponentNames {
    /// The names, as `fuse = [...]` spells them.
    const NAMES: [&'static str; 6];
}

/// `fuse = [...]`: which of a sample's six components are fused
/// (robot_localization's `odom0_config`); the others are left out of the
/// update, their correlations with the fused ones dropped (the marginal of the
/// fused ones), and the gate and the health count only the fused ones.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Components<N> {
    /// Whether each component is fused.
    pub mask: [bool; 6],
    names: PhantomData<N>,
}

impl<N> Default for Components<N> {
    /// All six.
    fn default() -> Self {
        Self { mask: [true; 6], names: PhantomData }
    }
}

impl<N> Components<N> {
    /// How many are fused.
    pub fn count(&self) -> usize {
        self.mask.iter().filter(|m| **m).count()
    }

    /// Whether all six are.
    pub fn all(&self) -> bool {
        self.count() == 6
    }
}

impl<'de, N: ComponentNames> Deserialize<'de> for Components<N> {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        let names = Vec::<String>::deserialize(d)?;
        let mut mask = [false; 6];
        for name in &names {
            let Some(i) = N::NAMES.iter().position(|n| n == name) else {
                return Err(serde::de::Error::custom(format!(
                    "unknown component {name:?}; the components are {}",
                    N::NAMES.join(", ")
                )));
            };
            mask[i] = true;
        }
        if !mask.contains(&true) {
            return Err(serde::de::Error::custom(format!(
                "selects no component; the components are {}",
                N::NAMES.join(", ")
            )));
        }
        Ok(Self { mask, names: PhantomData })
    }
}
