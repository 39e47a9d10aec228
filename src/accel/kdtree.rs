//! PLACEHOLDER: the SAH kd-tree builder (helper at work).
