//! What every conversion shares. A resource and its message mostly have the same fields under
//! the same names; they differ in how a few kinds of value travel: a count is a `usize` here
//! and a `u64` on the wire, an absent list or text is an empty one there, a message the other
//! side always sets is still optional in protobuf, an enum is an `i32`. [`Wire`] says, once per
//! kind of value, how it goes out and how it comes back (refusing what the resource cannot hold
//! with `INVALID_ARGUMENT`); [`both_ways!`] then writes a resource's two conversions from the
//! list of its fields, and [`enum_both_ways!`] an enum's, so that no field is spelled twice.

use tonic::Status;

/// An inbound conversion's result: `INVALID_ARGUMENT` for what the resource cannot hold.
pub(super) type In<T> = Result<T, Status>;

/// A message the sender must set.
pub(super) fn required<T>(v: Option<T>, what: &str) -> In<T> {
    v.ok_or_else(|| Status::invalid_argument(format!("{what} is required")))
}

pub(super) fn usize_from(v: u64, what: &str) -> In<usize> {
    usize::try_from(v).map_err(|_| Status::invalid_argument(format!("{what} is too large")))
}

/// A value of a resource's field as its message's field `M` carries it, and back (`what`: the
/// field's name, for the error).
pub(super) trait Wire<M>: Sized {
    fn out(self) -> M;
    fn back(m: M, what: &str) -> In<Self>;
}

/// Values that travel as they are.
macro_rules! same {
    ($($t:ty),* $(,)?) => {
        $(impl Wire<$t> for $t {
            fn out(self) -> $t {
                self
            }
            fn back(m: $t, _: &str) -> In<$t> {
                Ok(m)
            }
        })*
    };
}

same!(bool, i64, u32, u64, f64, String);

/// A count.
impl Wire<u64> for usize {
    fn out(self) -> u64 {
        self as u64
    }
    fn back(m: u64, what: &str) -> In<usize> {
        usize_from(m, what)
    }
}

/// An optional value: each way when present.
impl<T: Wire<M>, M> Wire<Option<M>> for Option<T> {
    fn out(self) -> Option<M> {
        self.map(Wire::out)
    }
    fn back(m: Option<M>, what: &str) -> In<Option<T>> {
        m.map(|m| T::back(m, what)).transpose()
    }
}

/// A list: each element.
impl<T: Wire<M>, M> Wire<Vec<M>> for Vec<T> {
    fn out(self) -> Vec<M> {
        self.into_iter().map(Wire::out).collect()
    }
    fn back(m: Vec<M>, what: &str) -> In<Vec<T>> {
        m.into_iter().map(|m| T::back(m, what)).collect()
    }
}

/// An optional list that protobuf cannot tell from an empty one: empty is absent.
impl<T> Wire<Vec<T>> for Option<Vec<T>> {
    fn out(self) -> Vec<T> {
        self.unwrap_or_default()
    }
    fn back(m: Vec<T>, _: &str) -> In<Option<Vec<T>>> {
        Ok((!m.is_empty()).then_some(m))
    }
}

/// An optional text that protobuf cannot tell from an empty one: empty is absent.
impl Wire<String> for Option<String> {
    fn out(self) -> String {
        self.unwrap_or_default()
    }
    fn back(m: String, _: &str) -> In<Option<String>> {
        Ok((!m.is_empty()).then_some(m))
    }
}

/// A resource and its message, field for field through [`Wire`]: `From` the resource to the
/// message, `TryFrom` the message back, and the resource as a field of other messages (once as
/// the message, once as a message that is always set: missing, it is `"{field} is required"`).
///
/// `$res` is the resource type in scope, `$msg` the message of `pb` of that name. `plain`
/// pairs, whose fields have the same types on both sides, convert with `From` both ways.
macro_rules! both_ways {
    ($res:ident => $msg:ident { $($field:ident),* $(,)? }) => {
        impl From<$res> for $crate::grpc::pb::$msg {
            fn from(v: $res) -> $crate::grpc::pb::$msg {
                $crate::grpc::pb::$msg {
                    $($field: $crate::grpc::convert::wire::Wire::out(v.$field),)*
                }
            }
        }

        impl TryFrom<$crate::grpc::pb::$msg> for $res {
            type Error = tonic::Status;
            fn try_from(m: $crate::grpc::pb::$msg) -> $crate::grpc::convert::wire::In<$res> {
                Ok($res {
                    $($field: $crate::grpc::convert::wire::Wire::back(
                        m.$field,
                        stringify!($field),
                    )?,)*
                })
            }
        }

        $crate::grpc::convert::wire::both_ways!(@field $res => $msg, m => m.try_into());
    };
    (plain $res:ident => $msg:ident { $($field:ident),* $(,)? }) => {
        impl From<$res> for $crate::grpc::pb::$msg {
            fn from(v: $res) -> $crate::grpc::pb::$msg {
                $crate::grpc::pb::$msg { $($field: v.$field,)* }
            }
        }

        impl From<$crate::grpc::pb::$msg> for $res {
            fn from(m: $crate::grpc::pb::$msg) -> $res {
                $res { $($field: m.$field,)* }
            }
        }

        $crate::grpc::convert::wire::both_ways!(@field $res => $msg, m => Ok(m.into()));
    };
    (@field $res:ident => $msg:ident, $m:ident => $back:expr) => {
        impl $crate::grpc::convert::wire::Wire<$crate::grpc::pb::$msg> for $res {
            fn out(self) -> $crate::grpc::pb::$msg {
                self.into()
            }
            fn back($m: $crate::grpc::pb::$msg, _: &str) -> $crate::grpc::convert::wire::In<$res> {
                $back
            }
        }

        impl $crate::grpc::convert::wire::Wire<Option<$crate::grpc::pb::$msg>> for $res {
            fn out(self) -> Option<$crate::grpc::pb::$msg> {
                Some(self.into())
            }
            fn back(m: Option<$crate::grpc::pb::$msg>, what: &str) -> $crate::grpc::convert::wire::In<$res> {
                let $m = $crate::grpc::convert::wire::required(m, what)?;
                $back
            }
        }
    };
}

/// An enum and its protobuf enum (an `i32` on the wire), variant for variant; the protobuf
/// one's `Unspecified` is no value. An optional field refuses an unknown number (`"unknown
/// {what} 7"`); a required one `Unspecified` too (`"{what} is required"`). A variant the
/// protobuf enum names otherwise is written `Variant = ProtobufVariant` (the wire keeps its
/// published name).
macro_rules! enum_both_ways {
    ($res:ident => $msg:ident as $what:literal { $($variant:ident $(= $wire:ident)?),* $(,)? }) => {
        impl From<$res> for $crate::grpc::pb::$msg {
            fn from(v: $res) -> $crate::grpc::pb::$msg {
                match v {
                    $($res::$variant => $crate::grpc::convert::wire::enum_both_ways!(
                        @pb $msg, $variant $($wire)?
                    ),)*
                }
            }
        }

        impl $crate::grpc::convert::wire::Wire<i32> for Option<$res> {
            fn out(self) -> i32 {
                self.map_or($crate::grpc::pb::$msg::Unspecified, Into::into).into()
            }
            fn back(m: i32, _: &str) -> $crate::grpc::convert::wire::In<Option<$res>> {
                match $crate::grpc::pb::$msg::try_from(m) {
                    Ok($crate::grpc::pb::$msg::Unspecified) => Ok(None),
                    $(Ok($crate::grpc::convert::wire::enum_both_ways!(@pb $msg, $variant $($wire)?))
                        => Ok(Some($res::$variant)),)*
                    Err(_) => Err(tonic::Status::invalid_argument(format!(
                        concat!("unknown ", $what, " {}"),
                        m
                    ))),
                }
            }
        }

        impl $crate::grpc::convert::wire::Wire<i32> for $res {
            fn out(self) -> i32 {
                $crate::grpc::pb::$msg::from(self).into()
            }
            fn back(m: i32, _: &str) -> $crate::grpc::convert::wire::In<$res> {
                <Option<$res> as $crate::grpc::convert::wire::Wire<i32>>::back(m, $what)?
                    .ok_or_else(|| {
                        tonic::Status::invalid_argument(concat!($what, " is required"))
                    })
            }
        }
    };
    // The protobuf variant of a variant: its own name, or the one given.
    (@pb $msg:ident, $variant:ident) => {
        $crate::grpc::pb::$msg::$variant
    };
    (@pb $msg:ident, $variant:ident $wire:ident) => {
        $crate::grpc::pb::$msg::$wire
    };
}

pub(super) use {both_ways, enum_both_ways};
