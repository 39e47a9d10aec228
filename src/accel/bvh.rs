//! PLACEHOLDER: the Morton-code BVH builder (helper at work).
