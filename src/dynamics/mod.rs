//! Dynamics (being written).
use crate::model::Model;

#[derive(Clone, Debug, Default)]
pub struct Tree<T> {
    _p: std::marker::PhantomData<T>,
}

impl<T> Tree<T> {
    pub fn empty() -> Self {
        Tree { _p: std::marker::PhantomData }
    }
    pub fn build(_m: &Model) -> Self {
        Self::empty()
    }
}
