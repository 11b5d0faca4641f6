//! One value per joint of an arm, for any arm of up to [`MAX_JOINTS`] joints.
//!
//! The model runs on the MCU without an allocator, so a joint vector is a
//! fixed array with a length: `Copy`, no heap, and a slice of exactly the
//! arm's joints wherever it is read ([`core::ops::Deref`] to `[T]`).

use core::fmt;
use core::ops::{Deref, DerefMut};

use serde::de::{Error as _, SeqAccess, Visitor};
use serde::ser::SerializeSeq;
use serde::{Deserialize, Deserializer, Serialize, Serializer};

/// The most joints an arm may have.
pub const MAX_JOINTS: usize = 10;

/// Up to `C` values along the chain, read as a slice of exactly those there are.
#[derive(Clone, Copy)]
pub struct ChainVec<T, const C: usize> {
    len: u8,
    items: [T; C],
}

/// One `T` per joint, base to tip: at most [`MAX_JOINTS`].
pub type PerJoint<T> = ChainVec<T, MAX_JOINTS>;

/// One `T` per frame of the chain, 0 (the base's) to n (the last joint's).
pub type PerFrame<T> = ChainVec<T, { MAX_JOINTS + 1 }>;

impl<T: Copy + Default, const C: usize> ChainVec<T, C> {
    /// `f(i)` for each joint `i` of `n`.
    ///
    /// # Panics
    /// If `n` exceeds [`MAX_JOINTS`]: every arm is checked against it when it
    /// is read, so a longer vector is a bug, not an input.
    // Always inlined, as `splat` and `eq`: the firmware is built for size,
    // where these stay calls, one per joint vector in every servo frame
    // (about 2,000 of the compensation step's cycles on the MCU).
    #[inline(always)]
    pub fn from_fn(n: usize, mut f: impl FnMut(usize) -> T) -> Self {
        assert!(n <= C, "{n} joints, at most {C}");
        let mut items = [T::default(); C];
        for (i, item) in items.iter_mut().enumerate().take(n) {
            *item = f(i);
        }
        Self {
            len: n as u8,
            items,
        }
    }

    /// `value` for each of `n` joints (panics as [`PerJoint::from_fn`]).
    #[inline(always)]
    pub fn splat(n: usize, value: T) -> Self {
        Self::from_fn(n, |_| value)
    }

    /// The values of `slice`, or `None` when it holds more than [`MAX_JOINTS`].
    pub fn from_slice(slice: &[T]) -> Option<Self> {
        (slice.len() <= C).then(|| Self::from_fn(slice.len(), |i| slice[i]))
    }

    /// `f` of each value.
    pub fn map<U: Copy + Default>(&self, mut f: impl FnMut(T) -> U) -> ChainVec<U, C> {
        ChainVec::from_fn(self.len(), |i| f(self[i]))
    }

    /// The last value (panics when empty, which no arm's vector is).
    pub fn last_value(&self) -> T {
        self[self.len() - 1]
    }
}

impl<T: Copy + Default, const C: usize> Default for ChainVec<T, C> {
    /// No values.
    fn default() -> Self {
        Self::splat(0, T::default())
    }
}

impl<T, const C: usize> Deref for ChainVec<T, C> {
    type Target = [T];

    fn deref(&self) -> &[T] {
        &self.items[..self.len as usize]
    }
}

impl<T, const C: usize> DerefMut for ChainVec<T, C> {
    fn deref_mut(&mut self) -> &mut [T] {
        &mut self.items[..self.len as usize]
    }
}

impl<T, const C: usize> IntoIterator for ChainVec<T, C> {
    type Item = T;
    type IntoIter = core::iter::Take<core::array::IntoIter<T, C>>;

    fn into_iter(self) -> Self::IntoIter {
        let len = self.len as usize;
        self.items.into_iter().take(len)
    }
}

impl<'a, T, const C: usize> IntoIterator for &'a ChainVec<T, C> {
    type Item = &'a T;
    type IntoIter = core::slice::Iter<'a, T>;

    fn into_iter(self) -> Self::IntoIter {
        self.iter()
    }
}

impl<'a, T, const C: usize> IntoIterator for &'a mut ChainVec<T, C> {
    type Item = &'a mut T;
    type IntoIter = core::slice::IterMut<'a, T>;

    fn into_iter(self) -> Self::IntoIter {
        self.iter_mut()
    }
}

impl<T: Copy + Default, const N: usize, const C: usize> From<[T; N]> for ChainVec<T, C> {
    /// # Panics
    /// If `N` exceeds [`MAX_JOINTS`].
    fn from(values: [T; N]) -> Self {
        Self::from_fn(N, |i| values[i])
    }
}

impl<T: PartialEq, const C: usize, const D: usize> PartialEq<ChainVec<T, D>> for ChainVec<T, C> {
    #[inline(always)]
    fn eq(&self, other: &ChainVec<T, D>) -> bool {
        **self == **other
    }
}

impl<T: PartialEq, const N: usize, const C: usize> PartialEq<[T; N]> for ChainVec<T, C> {
    fn eq(&self, other: &[T; N]) -> bool {
        **self == other[..]
    }
}

impl<T: fmt::Debug, const C: usize> fmt::Debug for ChainVec<T, C> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_list().entries(self.iter()).finish()
    }
}

impl<T: Serialize, const C: usize> Serialize for ChainVec<T, C> {
    fn serialize<S: Serializer>(&self, serializer: S) -> Result<S::Ok, S::Error> {
        let mut seq = serializer.serialize_seq(Some(self.len()))?;
        for item in self.iter() {
            seq.serialize_element(item)?;
        }
        seq.end()
    }
}

impl<'de, T: Copy + Default + Deserialize<'de>, const C: usize> Deserialize<'de>
    for ChainVec<T, C>
{
    fn deserialize<D: Deserializer<'de>>(deserializer: D) -> Result<Self, D::Error> {
        struct Values<T, const C: usize>(core::marker::PhantomData<T>);

        impl<'de, T: Copy + Default + Deserialize<'de>, const C: usize> Visitor<'de> for Values<T, C> {
            type Value = ChainVec<T, C>;

            fn expecting(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
                write!(f, "one value per joint, at most {C} of them")
            }

            fn visit_seq<A: SeqAccess<'de>>(self, mut seq: A) -> Result<Self::Value, A::Error> {
                let mut out = ChainVec::<T, C>::splat(0, T::default());
                while let Some(value) = seq.next_element()? {
                    if out.len() == C {
                        return Err(A::Error::invalid_length(C + 1, &self));
                    }
                    out.items[out.len()] = value;
                    out.len += 1;
                }
                Ok(out)
            }
        }

        deserializer.deserialize_seq(Values::<T, C>(core::marker::PhantomData))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reads_as_a_slice_of_its_length_only() {
        let q = PerJoint::from([1.0, 2.0, 3.0]);
        assert_eq!(q.len(), 3);
        assert_eq!(&*q, &[1.0, 2.0, 3.0]);
        assert_eq!(q.map(|x| x * 2.0), [2.0, 4.0, 6.0]);
        // Values past the length never take part in equality.
        let mut other = PerJoint::from([1.0, 2.0, 3.0, 9.0]);
        other.len = 3;
        assert_eq!(q, other);
        assert!(PerJoint::<f64>::from_slice(&[0.0; MAX_JOINTS + 1]).is_none());
    }

    #[test]
    fn serde_round_trip_and_refuses_too_many() {
        let q = PerJoint::from([0.5f32, -1.0, 2.0, 0.0, 1.0]);
        let mut buf = [0u8; 64];
        let bytes = postcard::to_slice(&q, &mut buf).unwrap();
        let back: PerJoint<f32> = postcard::from_bytes(bytes).unwrap();
        assert_eq!(back, q);
        let long = [0u8; MAX_JOINTS + 1];
        let bytes = postcard::to_slice(&long[..], &mut buf).unwrap();
        assert!(postcard::from_bytes::<PerJoint<u8>>(bytes).is_err());
    }
}
