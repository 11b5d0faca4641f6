//! What the poses can tell: the identification Jacobian ([`jacobian`]), the
//! identifiable parameter subset by rank analysis ([`identifiability`]),
//! column scaling and the observability indices ([`observability`]),
//! D-optimal pose selection ([`detmax`]), and the small triangular factor
//! that stands for a tall Jacobian in the rank analysis ([`triangular`]).

pub mod detmax;
pub mod identifiability;
pub mod jacobian;
pub mod observability;
pub mod triangular;
