//! What the poses can tell: the identification Jacobian ([`jacobian`]), the
//! identifiable parameter subset by rank analysis ([`identifiability`]),
//! column scaling and the observability indices ([`observability`]), and
//! D-optimal pose selection ([`detmax`]).

pub mod detmax;
pub mod identifiability;
pub mod jacobian;
pub mod observability;
