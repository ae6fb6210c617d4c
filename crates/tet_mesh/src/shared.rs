//! [`SharedArray`]: an array a mesh holds, either owned or shared
//! read-only with another owner — such as a bundle file mapped into memory,
//! whose pages the operating system reads in as they are used and may drop
//! again under memory pressure (so a mesh larger than memory can be held).

use std::fmt;
use std::ops::{Deref, DerefMut};
use std::sync::Arc;

/// An owned `Vec<T>`, or a read-only slice kept alive by an owner shared
/// through an `Arc` (e.g. a memory-mapped file's section). Reads go through
/// `Deref<Target = [T]>`; [`SharedArray::to_mut`] makes a shared array owned
/// (a copy) before the first write.
pub enum SharedArray<T: 'static> {
    Owned(Vec<T>),
    Shared(Arc<dyn AsRef<[T]> + Send + Sync>),
}

impl<T> SharedArray<T> {
    /// The array for writing: a shared one is copied into an owned one first.
    pub fn to_mut(&mut self) -> &mut Vec<T>
    where
        T: Clone,
    {
        if let SharedArray::Shared(s) = self {
            *self = SharedArray::Owned(s.as_ref().as_ref().to_vec());
        }
        match self {
            SharedArray::Owned(v) => v,
            SharedArray::Shared(_) => unreachable!("made owned above"),
        }
    }

    /// The array as a `Vec` (a shared one copied).
    pub fn into_vec(self) -> Vec<T>
    where
        T: Clone,
    {
        match self {
            SharedArray::Owned(v) => v,
            SharedArray::Shared(s) => s.as_ref().as_ref().to_vec(),
        }
    }

    /// Whether the storage is shared (not owned by this array).
    pub fn is_shared(&self) -> bool {
        matches!(self, SharedArray::Shared(_))
    }
}

impl<T> Deref for SharedArray<T> {
    type Target = [T];
    #[inline]
    fn deref(&self) -> &[T] {
        match self {
            SharedArray::Owned(v) => v,
            SharedArray::Shared(s) => s.as_ref().as_ref(),
        }
    }
}

/// Writing through a shared array copies it into an owned one first
/// ([`SharedArray::to_mut`]): copy on write.
impl<T: Clone> DerefMut for SharedArray<T> {
    fn deref_mut(&mut self) -> &mut [T] {
        self.to_mut()
    }
}

impl<T> From<Vec<T>> for SharedArray<T> {
    fn from(v: Vec<T>) -> Self {
        SharedArray::Owned(v)
    }
}

impl<T> FromIterator<T> for SharedArray<T> {
    fn from_iter<I: IntoIterator<Item = T>>(iter: I) -> Self {
        SharedArray::Owned(iter.into_iter().collect())
    }
}

impl<T> Default for SharedArray<T> {
    fn default() -> Self {
        SharedArray::Owned(Vec::new())
    }
}

impl<T: Clone> Clone for SharedArray<T> {
    fn clone(&self) -> Self {
        match self {
            SharedArray::Owned(v) => SharedArray::Owned(v.clone()),
            SharedArray::Shared(s) => SharedArray::Shared(Arc::clone(s)),
        }
    }
}

impl<T: fmt::Debug> fmt::Debug for SharedArray<T> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        fmt::Debug::fmt(&**self, f)
    }
}

impl<T: PartialEq> PartialEq for SharedArray<T> {
    fn eq(&self, other: &Self) -> bool {
        **self == **other
    }
}

impl<T: PartialEq> PartialEq<Vec<T>> for SharedArray<T> {
    fn eq(&self, other: &Vec<T>) -> bool {
        **self == **other
    }
}

impl<'a, T> IntoIterator for &'a SharedArray<T> {
    type Item = &'a T;
    type IntoIter = std::slice::Iter<'a, T>;
    fn into_iter(self) -> Self::IntoIter {
        self.iter()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    struct Held(Vec<u32>);
    impl AsRef<[u32]> for Held {
        fn as_ref(&self) -> &[u32] {
            &self.0
        }
    }

    #[test]
    fn shared_arrays_read_like_owned_and_copy_on_write() {
        let owned: SharedArray<u32> = vec![1, 2, 3].into();
        let mut shared = SharedArray::Shared(Arc::new(Held(vec![1, 2, 3])));
        assert_eq!(owned, shared);
        assert!(shared.is_shared() && !owned.is_shared());
        let copy = shared.clone();
        shared.to_mut().push(4);
        assert_eq!(&*shared, &[1, 2, 3, 4]);
        let mut written = copy.clone();
        written[0] = 9;
        assert!(!written.is_shared() && written[..] == [9, 2, 3]);
        assert_eq!(&*copy, &[1, 2, 3]);
        assert!(!shared.is_shared() && copy.is_shared());
        assert_eq!(copy.into_vec(), vec![1, 2, 3]);
    }
}
