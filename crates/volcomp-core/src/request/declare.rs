//! One declaration per option: a request's struct, its table of options
//! ([`OptionInfo`](super::OptionInfo)) and its `set`, written from one
//! plain list with one entry per option.

/// Declares a request from its option list.
///
/// ```text
/// request! {
///     /// A simulation, as plain values.
///     pub struct SimulateRequest {
///         /// The machine (a request inside this one: its options are set first).
///         pub machine: MachineRequest,
///     }
///     /// The options of [`SimulateRequest`] beside the machine's.
///     pub const SIMULATE_OPTIONS;
///     options [MACHINE_OPTIONS, SIMULATE_OPTIONS], unknown "reference";
///
///     /// Chord tolerance (mm).
///     chord_tolerance_mm: f64 = DEFAULT_CHORD_TOLERANCE_MM,
///         Number.flag("chord-tolerance").value("MM").default("0.00001"),
///         "Chord tolerance for linearising arcs and splines (mm).";
/// }
/// ```
///
/// The struct derives `Debug`, `Clone` and `PartialEq` (every request is
/// compared and copied the same way). Each option is one entry:
/// its field (rustdoc, name, type and default), the [`Kind`](super::Kind) of
/// its row in the table with the row's builder methods (flag, placeholder,
/// shown default, choices), then its help. The entry makes the field, the
/// row (named by the field) and the arm in `try_set`, which reads the value
/// by the field's type ([`FromValue`](super::option::FromValue)).
/// `options [...]` is the request's [`Request::OPTIONS`](super::Request::OPTIONS)
/// (the groups in help order); `unknown` the option a refused name is
/// reported against. A request that holds no other request writes
/// `pub const NAME_OPTIONS, unknown "…";` instead: its own table is its
/// only group.
macro_rules! request {
    (
        $(#[$meta:meta])*
        pub struct $name:ident {$($parts:tt)*}
        $(#[$table_meta:meta])*
        pub const $table:ident, unknown $unknown:literal;
        $($entries:tt)+
    ) => {
        request! {
            $(#[$meta])*
            pub struct $name {$($parts)*}
            $(#[$table_meta])*
            pub const $table;
            options [$table], unknown $unknown;
            $($entries)+
        }
    };
    (
        $(#[$meta:meta])*
        pub struct $name:ident {
            $($(#[$part_meta:meta])* pub $part:ident: $part_type:ty,)*
        }
        $(#[$table_meta:meta])*
        pub const $table:ident;
        options [$($group:ident),+], unknown $unknown:literal;
        $(
            $(#[$field_meta:meta])*
            $field:ident: $type:ty = $default:expr, $kind:ident $(.$with:ident($($arg:expr),*))*,
                $help:literal;
        )+
    ) => {
        $(#[$meta])*
        #[derive(Debug, Clone, PartialEq)]
        pub struct $name {
            $($(#[$part_meta])* pub $part: $part_type,)*
            $($(#[$field_meta])* pub $field: $type,)+
        }

        impl Default for $name {
            fn default() -> Self {
                Self {
                    $($part: Default::default(),)*
                    $($field: $default,)+
                }
            }
        }

        $(#[$table_meta])*
        pub const $table: &[$crate::request::OptionInfo] = &[$(
            $crate::request::OptionInfo::new(
                stringify!($field),
                $crate::request::Kind::$kind,
                $help,
            )$(.$with($($arg),*))*,
        )+];

        impl $name {
            /// Sets the option `name` (of a request inside this one, or of
            /// its own table); `Ok(false)` when it has no option `name`.
            pub fn try_set(
                &mut self,
                name: &str,
                value: $crate::request::Value,
            ) -> Result<bool, $crate::request::OptionError> {
                $(if self.$part.try_set(name, value.clone())? {
                    return Ok(true);
                })*
                match name {
                    $(stringify!($field) => {
                        self.$field = $crate::request::option::FromValue::from_value(
                            value,
                            $crate::request::Kind::$kind,
                            stringify!($field),
                        )?
                    })+
                    _ => return Ok(false),
                }
                Ok(true)
            }
        }

        impl $crate::request::Request for $name {
            const OPTIONS: &'static [&'static [$crate::request::OptionInfo]] = &[$($group),+];

            fn set(
                &mut self,
                name: &str,
                value: $crate::request::Value,
            ) -> Result<(), $crate::request::OptionError> {
                if self.try_set(name, value)? {
                    Ok(())
                } else {
                    Err($crate::request::OptionError::unknown($unknown, name))
                }
            }
        }
    };
}
