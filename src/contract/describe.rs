//! What the C header and the device's layout probe need to know of each shared item, and the
//! macro that declares an item once for both: the Rust definition and its description.

/// A type a shared struct's field may have, by its OpenCL C spelling.
pub trait CType {
    /// The C type of the field, or of each element of an array.
    const NAME: &'static str;
    /// An array's length; 0 for a scalar or a struct.
    const LEN: usize = 0;
}

impl CType for u32 {
    const NAME: &'static str = "uint";
}

impl CType for f32 {
    const NAME: &'static str = "float";
}

impl<T: CType, const N: usize> CType for [T; N] {
    const NAME: &'static str = T::NAME;
    const LEN: usize = N;
}

/// A `#define` shared by host and kernels.
pub struct ConstDef {
    pub name: &'static str,
    pub value: u32,
    /// The Rust doc comment's lines: the C comment too.
    pub doc: &'static [&'static str],
}

/// A field of a shared struct.
pub struct Field {
    pub name: &'static str,
    /// [`CType::NAME`] of its type.
    pub c_type: &'static str,
    /// [`CType::LEN`] of its type.
    pub len: usize,
    /// Rust's `offset_of!`, which the device probe compares with C's `offsetof`.
    pub offset: usize,
    pub doc: &'static [&'static str],
}

/// A struct shared by host and kernels.
pub struct StructDef {
    pub name: &'static str,
    pub size: usize,
    pub doc: &'static [&'static str],
    pub fields: &'static [Field],
}

/// One declaration of `kernels/types.h`, in its order.
pub enum Item {
    Const(ConstDef),
    Struct(StructDef),
}

/// Declares shared constants (`pub const NAME: u32 = value;`) and structs (`pub struct Name {
/// pub field: type, }` of `u32`, `f32`, arrays of them and other shared structs), each with
/// its doc comment, and `ITEMS`, their descriptions in order. A struct is `#[repr(C)]`, `Pod`
/// (so it has no padding that compilers could lay out differently) and a [`CType`].
macro_rules! shared {
    (@items [$($item:expr,)*]) => {
        /// Every shared constant and struct, in the order `kernels/types.h` declares them.
        pub const ITEMS: &[$crate::contract::Item] = &[$($item,)*];
    };
    (@items [$($item:expr,)*]
        $(#[doc = $doc:literal])*
        pub const $name:ident: u32 = $value:expr;
        $($rest:tt)*
    ) => {
        $(#[doc = $doc])*
        pub const $name: u32 = $value;
        shared!(@items [$($item,)* $crate::contract::Item::Const($crate::contract::ConstDef {
            name: stringify!($name),
            value: $name,
            doc: &[$($doc),*],
        }),] $($rest)*);
    };
    (@items [$($item:expr,)*]
        $(#[doc = $doc:literal])*
        pub struct $name:ident {
            $($(#[doc = $fdoc:literal])* pub $field:ident: $ty:ty,)*
        }
        $($rest:tt)*
    ) => {
        $(#[doc = $doc])*
        #[repr(C)]
        #[derive(Clone, Copy, Debug, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
        pub struct $name {
            $($(#[doc = $fdoc])* pub $field: $ty,)*
        }
        impl $crate::contract::CType for $name {
            const NAME: &'static str = stringify!($name);
        }
        shared!(@items [$($item,)* $crate::contract::Item::Struct($crate::contract::StructDef {
            name: stringify!($name),
            size: std::mem::size_of::<$name>(),
            doc: &[$($doc),*],
            fields: &[$($crate::contract::Field {
                name: stringify!($field),
                c_type: <$ty as $crate::contract::CType>::NAME,
                len: <$ty as $crate::contract::CType>::LEN,
                offset: std::mem::offset_of!($name, $field),
                doc: &[$($fdoc),*],
            }),*],
        }),] $($rest)*);
    };
    ($($items:tt)*) => {
        shared!(@items [] $($items)*);
    };
}
