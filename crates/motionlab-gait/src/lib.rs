//! # motionlab-gait
//!
//! Walk analysis and control after Osafune et al. (see SPEC section 003).
