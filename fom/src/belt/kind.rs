//! The belt's kind (`belt.kind`): plain configuration data (`config::BeltKind`). What a kind
//! changes in the model is its friction coefficient (`statics::effective_friction`, used by
//! `contact::ContactLaw::from_config`) and, for a toothed belt, the tooth-groove contact
//! (`contact::tooth`). The step loop does not name kinds.

pub use crate::config::BeltKind;
