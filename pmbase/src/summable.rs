//! [`summable!`](crate::summable): statistics structs whose `AddAssign` adds each field to itself.
#![forbid(unsafe_code)]

/// Defines a statistics struct together with an `AddAssign` that adds every field of the other value to
/// the same field (`self.f += other.f` for each field, in declaration order), so that per-thread
/// statistics merge with rayon's `fold`/`reduce` and a new field cannot be forgotten in the merge.
///
/// Every field's type must be `AddAssign` (counts, seconds, bytes, nested statistics). A struct with a
/// field that merges otherwise (a maximum, a histogram's extremes) writes its `AddAssign` by hand.
///
/// ```
/// pmbase::summable! {
///     /// What a pass did.
///     #[derive(Clone, Copy, Debug, Default, PartialEq)]
///     pub struct PassStats {
///         pub n_rays: u64,
///         /// Wall-clock seconds.
///         pub seconds: f64,
///     }
/// }
/// let mut a = PassStats { n_rays: 2, seconds: 0.5 };
/// a += PassStats { n_rays: 3, seconds: 0.25 };
/// assert_eq!(a, PassStats { n_rays: 5, seconds: 0.75 });
/// ```
#[macro_export]
macro_rules! summable {
    (
        $(#[$meta:meta])*
        $vis:vis struct $name:ident {
            $(
                $(#[$field_meta:meta])*
                $field_vis:vis $field:ident : $ty:ty
            ),* $(,)?
        }
    ) => {
        $(#[$meta])*
        $vis struct $name {
            $(
                $(#[$field_meta])*
                $field_vis $field: $ty,
            )*
        }

        impl ::std::ops::AddAssign for $name {
            fn add_assign(&mut self, other: Self) {
                $(self.$field += other.$field;)*
            }
        }
    };
}

#[cfg(test)]
mod tests {
    crate::summable! {
        #[derive(Clone, Copy, Debug, Default, PartialEq)]
        struct Inner {
            n: u32,
        }
    }

    crate::summable! {
        #[derive(Clone, Copy, Debug, Default, PartialEq)]
        struct Outer {
            a: u64,
            inner: Inner,
            s: f64,
        }
    }

    #[test]
    fn adds_every_field_including_nested_statistics() {
        let mut x = Outer {
            a: 1,
            inner: Inner { n: 2 },
            s: 0.5,
        };
        x += x;
        assert_eq!(
            x,
            Outer {
                a: 2,
                inner: Inner { n: 4 },
                s: 1.0
            }
        );
    }
}
