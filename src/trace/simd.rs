//! One way to run a piece of code with the widest vector instructions the processor has:
//! [`dispatch`]. The tracer and the CSL bake write their hot loops once, as portable Rust
//! (`#[inline(always)]` helpers, some calling AVX intrinsics behind a `const` flag); the macro
//! compiles that code again for each listed instruction set (`#[target_feature]`), picks at
//! run time the first set the processor has, and falls back to the portable build. Every build
//! performs the same operations (no fused multiply-adds are asked for), so the results do not
//! depend on the machine.

/// Call `body` compiled for the first of the listed `target_feature`s the processor has, or as
/// it is where it has none of them (and on other architectures than x86-64):
///
/// ```text
/// crate::trace::simd::dispatch!(
///     ["avx512f", "avx2"],
///     fn(terms: &Terms = self, p: [f64; 5]) -> f64 { terms.sum(p) }
/// )
/// ```
///
/// - The features, in order of preference, are string literals as `#[target_feature(enable)]`
///   takes them (each build enables exactly one of them, with what it implies).
/// - The body is the body of a function with the given parameters and return type (it cannot
///   see the caller's other variables, nor `self` or `Self`: pass them as parameters, under
///   another name). Each parameter is passed the caller's variable of its name, or the value
///   after its `=`.
/// - `as NAME` after the features declares `const NAME: bool` in the body: true in the builds
///   for a feature, false in the portable one, for code that calls intrinsics itself (it may
///   use those that every listed feature enables).
///
/// Detection is std's `is_x86_feature_detected!`, which is cached (an atomic load after the
/// first call), at each call of the macro.
macro_rules! dispatch {
    (
        [$($feature:tt),+ $(,)?] $(as $wide:tt)?,
        fn($($arg:ident: $ty:ty $(= $val:expr)?),* $(,)?) $(-> $ret:ty)? $body:block
    ) => {{
        #[inline(always)]
        fn simd_dispatch($($arg: $ty),*) $(-> $ret)? {
            $crate::trace::simd::dispatch!(
                @clones [$($feature),+] [$($wide)?] ($($arg: $ty),*) [$($ret)?] $body
            );
            $crate::trace::simd::dispatch!(@wide [$($wide)?] false);
            $body
        }
        simd_dispatch($($crate::trace::simd::dispatch!(@value $arg $($val)?)),*)
    }};
    // One build per feature, tried in order; each returns from `simd_dispatch` when taken.
    (@clones [] $wide:tt $params:tt $ret:tt $body:block) => {};
    (
        @clones [$feature:tt $(, $rest:tt)*] $wide:tt ($($arg:ident: $ty:ty),*)
        [$($ret:ty)?] $body:block
    ) => {
        #[cfg(target_arch = "x86_64")]
        {
            #[target_feature(enable = $feature)]
            fn simd_clone($($arg: $ty),*) $(-> $ret)? {
                $crate::trace::simd::dispatch!(@wide $wide true);
                $body
            }
            if ::std::arch::is_x86_feature_detected!($feature) {
                // SAFETY: the processor has `$feature` (detected just above), the one feature
                // `simd_clone` is compiled with.
                return unsafe { simd_clone($($arg),*) };
            }
        }
        $crate::trace::simd::dispatch!(@clones [$($rest),*] $wide ($($arg: $ty),*) [$($ret)?] $body);
    };
    (@wide [] $value:tt) => {};
    (@wide [$wide:tt] $value:tt) => {
        const $wide: bool = $value;
    };
    (@value $arg:ident) => {
        $arg
    };
    (@value $arg:ident $val:expr) => {
        $val
    };
}

pub(crate) use dispatch;

#[cfg(test)]
mod tests {
    #[test]
    fn dispatch_takes_the_first_build_the_processor_has() {
        // `as NAME` is true in the builds for a feature, false in the portable one.
        let wide = dispatch!(["avx512f", "avx2"] as WIDE, fn() -> bool { WIDE });
        #[cfg(target_arch = "x86_64")]
        assert_eq!(
            wide,
            std::arch::is_x86_feature_detected!("avx512f")
                || std::arch::is_x86_feature_detected!("avx2")
        );
        #[cfg(not(target_arch = "x86_64"))]
        assert!(!wide);
        // Parameters take the caller's variable of their name or the value given; the body may
        // write through a `&mut` one and return nothing.
        let (x, y) = (3u32, 4u32);
        let mut out = 0;
        dispatch!(
            ["avx2"],
            fn(x: u32, z: u32 = y + 1, out: &mut u32 = &mut out) { *out = x * z }
        );
        assert_eq!(out, 15);
    }
}
