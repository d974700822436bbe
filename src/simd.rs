//! Eight `f32` lanes as one value, [`F8`]: arithmetic, comparisons into lane masks ([`M8`]) and
//! selects, written once. On x86-64 an `F8` is an AVX2 vector — the eight-lane form of the
//! geometry's SIMD tests (the BVH's node test and the small-scene scan, `geometry/wide.rs`) and
//! the lanes of paths traced in lockstep (the line-of-sight path tracer's and their ray packets) —
//! and its operations must run inside functions compiled for AVX2 (and FMA for
//! [`F8::mul_add`]: `#[target_feature(enable = "avx2,fma")]`, after run-time detection:
//! [`available`]); elsewhere it is an array, lane by lane. Either way every lane is rounded as the
//! scalar operation would be (multiply-adds fused in both), so the two give the same bits.
//! `on_cpu!` compiles such code a second time for AVX-512 (the same eight lanes, with mask
//! registers), where the CPU has it.

/// Lanes per value.
pub const LANES: usize = 8;

/// Whether this CPU runs [`F8`]'s vector form (AVX2 with FMA); elsewhere than x86-64, its array
/// form always runs.
pub fn available() -> bool {
    #[cfg(target_arch = "x86_64")]
    {
        std::arch::is_x86_feature_detected!("avx2") && std::arch::is_x86_feature_detected!("fma")
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        true
    }
}

/// Whether this CPU also runs AVX-512's foundation and its 256-bit forms (F and VL), for which
/// `on_cpu!` compiles [`F8`]'s operations a second time: the lanes stay eight, but compares set
/// mask registers (no blend of a vector mask) and 32 vector registers hold more of a loop.
pub fn wide_available() -> bool {
    #[cfg(target_arch = "x86_64")]
    {
        available()
            && std::arch::is_x86_feature_detected!("avx512f")
            && std::arch::is_x86_feature_detected!("avx512vl")
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        false
    }
}

/// `on_cpu!(wide, f(a: A, b: B) -> R)` calls `f(a, b)`, an `#[inline(always)]` function of
/// [`F8`]'s operations, compiled for AVX-512 F and VL where `wide` (which only
/// [`wide_available`] may set) and for AVX2 and FMA elsewhere: the same lanes, rounded alike, so
/// both give the same bits. Unsafe: the CPU must run AVX2 and FMA ([`available`]).
macro_rules! on_cpu {
    ($wide:expr, $f:ident($($a:ident: $t:ty),*) -> $r:ty) => {{
        #[cfg_attr(target_arch = "x86_64", target_feature(enable = "avx2,fma,avx512f,avx512vl"))]
        unsafe fn wide($($a: $t),*) -> $r {
            unsafe { $f($($a),*) }
        }
        #[cfg_attr(target_arch = "x86_64", target_feature(enable = "avx2,fma"))]
        unsafe fn narrow($($a: $t),*) -> $r {
            unsafe { $f($($a),*) }
        }
        if $wide { wide($($a),*) } else { narrow($($a),*) }
    }};
}
pub(crate) use on_cpu;

/// `make(wide)` for each form of [`F8`]'s code that `on_cpu!` picks from and this CPU runs:
/// AVX-512's first where `wide`, then AVX2's (for tests that compare them).
pub fn each_form<T>(wide: bool, make: impl Fn(bool) -> T) -> Vec<T> {
    [true, false]
        .into_iter()
        .filter(|&w| wide || !w)
        .map(make)
        .collect()
}

#[cfg(target_arch = "x86_64")]
mod imp {
    use super::LANES;
    use std::arch::x86_64::*;

    /// Eight lanes in an AVX2 vector.
    #[derive(Clone, Copy, Debug)]
    pub struct F8(__m256);

    /// A lane mask: all ones or all zeros per lane.
    #[derive(Clone, Copy, Debug)]
    pub struct M8(__m256);

    // SAFETY (every `unsafe` block below): the operations are AVX2 instructions (FMA for
    // `mul_add`), inlined only into functions compiled for them and run after their run-time
    // detection.
    impl F8 {
        /// `x` in every lane.
        #[inline(always)]
        pub fn splat(x: f32) -> Self {
            Self(unsafe { _mm256_set1_ps(x) })
        }
        /// The lanes from an array.
        #[inline(always)]
        pub fn load(a: &[f32; LANES]) -> Self {
            Self(unsafe { _mm256_loadu_ps(a.as_ptr()) })
        }
        /// The lanes into an array.
        #[inline(always)]
        pub fn store(self) -> [f32; LANES] {
            let mut a = [0.0; LANES];
            self.store_into(&mut a);
            a
        }
        /// The lanes into `a`.
        #[inline(always)]
        pub fn store_into(self, a: &mut [f32; LANES]) {
            unsafe { _mm256_storeu_ps(a.as_mut_ptr(), self.0) };
        }
        /// The lanes truncated to integers (as `x as i32` for lanes within its range).
        #[inline(always)]
        pub fn to_int(self) -> [i32; LANES] {
            let mut a = [0; LANES];
            unsafe { _mm256_storeu_si256(a.as_mut_ptr().cast(), _mm256_cvttps_epi32(self.0)) };
            a
        }
        /// The lanes whose bits are `a`'s.
        #[inline(always)]
        pub fn load_bits(a: &[u32; LANES]) -> Self {
            Self(unsafe { _mm256_castsi256_ps(_mm256_loadu_si256(a.as_ptr().cast())) })
        }
        /// The least lane (no lane is NaN).
        #[inline(always)]
        pub fn reduce_min(self) -> f32 {
            unsafe {
                let m = _mm_min_ps(
                    _mm256_castps256_ps128(self.0),
                    _mm256_extractf128_ps::<1>(self.0),
                );
                let m = _mm_min_ps(m, _mm_movehl_ps(m, m));
                _mm_cvtss_f32(_mm_min_ss(m, _mm_shuffle_ps::<1>(m, m)))
            }
        }
        /// The lanes where the sign bits of `a`, `b` and `c` are not all equal. Only each lane's
        /// sign bit is set right: the bit that selects and [`M8::bits`] read, and that the masks'
        /// bitwise logic combines lane by lane.
        #[inline(always)]
        pub fn signs_differ(a: Self, b: Self, c: Self) -> M8 {
            unsafe {
                M8(_mm256_or_ps(
                    _mm256_xor_ps(a.0, b.0),
                    _mm256_xor_ps(a.0, c.0),
                ))
            }
        }
        /// self · b + c, rounded once.
        #[inline(always)]
        pub fn mul_add(self, b: Self, c: Self) -> Self {
            Self(unsafe { _mm256_fmadd_ps(self.0, b.0, c.0) })
        }
        /// The lane-wise square root.
        #[inline(always)]
        pub fn sqrt(self) -> Self {
            Self(unsafe { _mm256_sqrt_ps(self.0) })
        }
        /// The lane-wise maximum (`b` where either is NaN).
        #[inline(always)]
        pub fn max(self, b: Self) -> Self {
            Self(unsafe { _mm256_max_ps(self.0, b.0) })
        }
        /// The lane-wise minimum (`b` where either is NaN).
        #[inline(always)]
        pub fn min(self, b: Self) -> Self {
            Self(unsafe { _mm256_min_ps(self.0, b.0) })
        }
        /// The lane-wise absolute value.
        #[inline(always)]
        pub fn abs(self) -> Self {
            Self(unsafe { _mm256_andnot_ps(_mm256_set1_ps(-0.0), self.0) })
        }
        /// 1 with each lane's sign (−1 for −0, as `f32::signum`; no lane is NaN).
        #[inline(always)]
        pub fn signum(self) -> Self {
            unsafe {
                Self(_mm256_or_ps(
                    _mm256_and_ps(self.0, _mm256_set1_ps(-0.0)),
                    _mm256_set1_ps(1.0),
                ))
            }
        }
        /// Lanes where self < b.
        #[inline(always)]
        pub fn lt(self, b: Self) -> M8 {
            M8(unsafe { _mm256_cmp_ps::<_CMP_LT_OQ>(self.0, b.0) })
        }
        /// Lanes where self ≤ b.
        #[inline(always)]
        pub fn le(self, b: Self) -> M8 {
            M8(unsafe { _mm256_cmp_ps::<_CMP_LE_OQ>(self.0, b.0) })
        }
        /// Lanes where self > b.
        #[inline(always)]
        pub fn gt(self, b: Self) -> M8 {
            M8(unsafe { _mm256_cmp_ps::<_CMP_GT_OQ>(self.0, b.0) })
        }
        /// Lanes where self ≥ b.
        #[inline(always)]
        pub fn ge(self, b: Self) -> M8 {
            M8(unsafe { _mm256_cmp_ps::<_CMP_GE_OQ>(self.0, b.0) })
        }
        /// Not equal, or either is NaN.
        #[inline(always)]
        pub fn ne(self, b: Self) -> M8 {
            M8(unsafe { _mm256_cmp_ps::<_CMP_NEQ_UQ>(self.0, b.0) })
        }
        /// Lanes where self = b.
        #[inline(always)]
        pub fn eq(self, b: Self) -> M8 {
            M8(unsafe { _mm256_cmp_ps::<_CMP_EQ_OQ>(self.0, b.0) })
        }
        /// `a` in the lanes of `m`, `b` in the others.
        #[inline(always)]
        pub fn select(m: M8, a: Self, b: Self) -> Self {
            Self(unsafe { _mm256_blendv_ps(b.0, a.0, m.0) })
        }
    }

    impl M8 {
        /// Bit `i` set where lane `i` is.
        #[inline(always)]
        pub fn bits(self) -> u32 {
            unsafe { _mm256_movemask_ps(self.0) as u32 }
        }
        /// The lanes of the bits `bits`.
        #[inline(always)]
        pub fn from_bits(bits: u32) -> Self {
            unsafe {
                let lane = _mm256_setr_epi32(1, 2, 4, 8, 16, 32, 64, 128);
                let set = _mm256_and_si256(_mm256_set1_epi32(bits as i32), lane);
                Self(_mm256_castsi256_ps(_mm256_cmpeq_epi32(set, lane)))
            }
        }
    }

    macro_rules! binary {
        ($t:ident, $f:ident, $i:ident) => {
            impl std::ops::$t for F8 {
                type Output = Self;
                #[inline(always)]
                fn $f(self, b: Self) -> Self {
                    Self(unsafe { $i(self.0, b.0) })
                }
            }
        };
    }
    binary!(Add, add, _mm256_add_ps);
    binary!(Sub, sub, _mm256_sub_ps);
    binary!(Mul, mul, _mm256_mul_ps);
    binary!(Div, div, _mm256_div_ps);

    macro_rules! logic {
        ($t:ident, $f:ident, $i:ident) => {
            impl std::ops::$t for M8 {
                type Output = Self;
                #[inline(always)]
                fn $f(self, b: Self) -> Self {
                    Self(unsafe { $i(self.0, b.0) })
                }
            }
        };
    }
    logic!(BitAnd, bitand, _mm256_and_ps);
    logic!(BitOr, bitor, _mm256_or_ps);

    impl std::ops::Not for M8 {
        type Output = Self;
        #[inline(always)]
        fn not(self) -> Self {
            Self(unsafe { _mm256_xor_ps(self.0, _mm256_castsi256_ps(_mm256_set1_epi32(-1))) })
        }
    }

    impl std::ops::Neg for F8 {
        type Output = Self;
        #[inline(always)]
        fn neg(self) -> Self {
            Self(unsafe { _mm256_xor_ps(self.0, _mm256_set1_ps(-0.0)) })
        }
    }
}

#[cfg(not(target_arch = "x86_64"))]
mod imp {
    use super::LANES;

    /// Eight lanes in an array.
    #[derive(Clone, Copy, Debug)]
    pub struct F8([f32; LANES]);

    /// A lane mask: a bit per lane.
    #[derive(Clone, Copy, Debug)]
    pub struct M8(u32);

    impl F8 {
        #[inline(always)]
        fn map2(self, b: Self, f: impl Fn(f32, f32) -> f32) -> Self {
            Self(std::array::from_fn(|l| f(self.0[l], b.0[l])))
        }
        #[inline(always)]
        fn test(self, b: Self, f: impl Fn(f32, f32) -> bool) -> M8 {
            M8((0..LANES).fold(0, |m, l| m | (f(self.0[l], b.0[l]) as u32) << l))
        }
        /// `x` in every lane.
        pub fn splat(x: f32) -> Self {
            Self([x; LANES])
        }
        /// The lanes from an array.
        pub fn load(a: &[f32; LANES]) -> Self {
            Self(*a)
        }
        /// The lanes into an array.
        pub fn store(self) -> [f32; LANES] {
            self.0
        }
        /// The lanes truncated to integers (as `x as i32` for lanes within its range).
        pub fn to_int(self) -> [i32; LANES] {
            self.0.map(|x| x as i32)
        }
        /// self · b + c, rounded once.
        pub fn mul_add(self, b: Self, c: Self) -> Self {
            Self(std::array::from_fn(|l| self.0[l].mul_add(b.0[l], c.0[l])))
        }
        /// The lane-wise square root.
        pub fn sqrt(self) -> Self {
            Self(self.0.map(f32::sqrt))
        }
        /// The lane-wise maximum (`b` where either is NaN).
        pub fn max(self, b: Self) -> Self {
            self.map2(b, |a, b| if a > b { a } else { b })
        }
        /// The lane-wise minimum (`b` where either is NaN).
        pub fn min(self, b: Self) -> Self {
            self.map2(b, |a, b| if a < b { a } else { b })
        }
        /// The lane-wise absolute value.
        pub fn abs(self) -> Self {
            Self(self.0.map(f32::abs))
        }
        /// 1 with each lane's sign (−1 for −0, as `f32::signum`; no lane is NaN).
        pub fn signum(self) -> Self {
            Self(self.0.map(f32::signum))
        }
        /// Lanes where self < b.
        pub fn lt(self, b: Self) -> M8 {
            self.test(b, |a, b| a < b)
        }
        /// Lanes where self ≤ b.
        pub fn le(self, b: Self) -> M8 {
            self.test(b, |a, b| a <= b)
        }
        /// Lanes where self > b.
        pub fn gt(self, b: Self) -> M8 {
            self.test(b, |a, b| a > b)
        }
        /// Lanes where self ≥ b.
        pub fn ge(self, b: Self) -> M8 {
            self.test(b, |a, b| a >= b)
        }
        /// Not equal, or either is NaN.
        pub fn ne(self, b: Self) -> M8 {
            self.test(b, |a, b| a != b)
        }
        /// Lanes where self = b.
        pub fn eq(self, b: Self) -> M8 {
            self.test(b, |a, b| a == b)
        }
        /// `a` in the lanes of `m`, `b` in the others.
        pub fn select(m: M8, a: Self, b: Self) -> Self {
            Self(std::array::from_fn(|l| {
                if m.0 >> l & 1 != 0 { a.0[l] } else { b.0[l] }
            }))
        }
    }

    impl M8 {
        /// Bit `i` set where lane `i` is.
        pub fn bits(self) -> u32 {
            self.0
        }
        /// The lanes of the bits `bits`.
        pub fn from_bits(bits: u32) -> Self {
            Self(bits & 0xff)
        }
    }

    macro_rules! binary {
        ($t:ident, $f:ident, $op:tt) => {
            impl std::ops::$t for F8 {
                type Output = Self;
                fn $f(self, b: Self) -> Self {
                    self.map2(b, |a, b| a $op b)
                }
            }
        };
    }
    binary!(Add, add, +);
    binary!(Sub, sub, -);
    binary!(Mul, mul, *);
    binary!(Div, div, /);

    impl std::ops::BitAnd for M8 {
        type Output = Self;
        fn bitand(self, b: Self) -> Self {
            Self(self.0 & b.0)
        }
    }
    impl std::ops::BitOr for M8 {
        type Output = Self;
        fn bitor(self, b: Self) -> Self {
            Self(self.0 | b.0)
        }
    }
    impl std::ops::Not for M8 {
        type Output = Self;
        fn not(self) -> Self {
            Self(!self.0 & 0xff)
        }
    }

    impl std::ops::Neg for F8 {
        type Output = Self;
        fn neg(self) -> Self {
            Self(self.0.map(|x| -x))
        }
    }
}

pub use imp::{F8, M8};

impl From<f32> for F8 {
    /// `x` in every lane.
    #[inline(always)]
    fn from(x: f32) -> Self {
        Self::splat(x)
    }
}

/// What arithmetic written once for an `f32` or for lanes of them ([`F8`]) needs: the four
/// operations, constants, the square root, comparisons and selection, each rounded as the `f32`
/// operation is, so that both forms give the same bits.
pub trait Real:
    Copy
    + From<f32>
    + std::ops::Add<Output = Self>
    + std::ops::Sub<Output = Self>
    + std::ops::Mul<Output = Self>
    + std::ops::Div<Output = Self>
    + std::ops::Neg<Output = Self>
{
    /// Which lanes a comparison holds in (a `bool` for an `f32`).
    type Mask: Copy
        + std::ops::BitAnd<Output = Self::Mask>
        + std::ops::BitOr<Output = Self::Mask>
        + std::ops::Not<Output = Self::Mask>;
    /// The square root.
    fn sqrt(self) -> Self;
    /// 1 with the sign of `self` (−1 for −0; not NaN).
    fn signum(self) -> Self;
    /// The absolute value.
    fn abs(self) -> Self;
    /// The greater of `self` and `b` (`b` where `self` is NaN; used against constants only).
    fn max(self, b: Self) -> Self;
    /// Where `self` < `b`.
    fn lt(self, b: Self) -> Self::Mask;
    /// Where `self` ≤ `b`.
    fn le(self, b: Self) -> Self::Mask;
    /// Where `self` > `b`.
    fn gt(self, b: Self) -> Self::Mask;
    /// Where `self` ≥ `b`.
    fn ge(self, b: Self) -> Self::Mask;
    /// Where `self` = `b`.
    fn eq(self, b: Self) -> Self::Mask;
    /// `a` where `m` holds, else `b` (both already computed).
    fn select(m: Self::Mask, a: Self, b: Self) -> Self;
    /// `f` of each lane: a scalar function such as `exp`, called lane by lane (its bits).
    fn each(self, f: impl Fn(f32) -> f32) -> Self;
}

impl Real for f32 {
    type Mask = bool;
    #[inline(always)]
    fn sqrt(self) -> Self {
        f32::sqrt(self)
    }
    #[inline(always)]
    fn signum(self) -> Self {
        f32::signum(self)
    }
    #[inline(always)]
    fn abs(self) -> Self {
        f32::abs(self)
    }
    #[inline(always)]
    fn max(self, b: Self) -> Self {
        f32::max(self, b)
    }
    #[inline(always)]
    fn lt(self, b: Self) -> bool {
        self < b
    }
    #[inline(always)]
    fn le(self, b: Self) -> bool {
        self <= b
    }
    #[inline(always)]
    fn gt(self, b: Self) -> bool {
        self > b
    }
    #[inline(always)]
    fn ge(self, b: Self) -> bool {
        self >= b
    }
    #[inline(always)]
    fn eq(self, b: Self) -> bool {
        self == b
    }
    #[inline(always)]
    fn select(m: bool, a: Self, b: Self) -> Self {
        if m { a } else { b }
    }
    #[inline(always)]
    fn each(self, f: impl Fn(f32) -> f32) -> Self {
        f(self)
    }
}

impl Real for F8 {
    type Mask = M8;
    #[inline(always)]
    fn sqrt(self) -> Self {
        F8::sqrt(self)
    }
    #[inline(always)]
    fn signum(self) -> Self {
        F8::signum(self)
    }
    #[inline(always)]
    fn abs(self) -> Self {
        F8::abs(self)
    }
    #[inline(always)]
    fn max(self, b: Self) -> Self {
        F8::max(self, b)
    }
    #[inline(always)]
    fn lt(self, b: Self) -> M8 {
        F8::lt(self, b)
    }
    #[inline(always)]
    fn le(self, b: Self) -> M8 {
        F8::le(self, b)
    }
    #[inline(always)]
    fn gt(self, b: Self) -> M8 {
        F8::gt(self, b)
    }
    #[inline(always)]
    fn ge(self, b: Self) -> M8 {
        F8::ge(self, b)
    }
    #[inline(always)]
    fn eq(self, b: Self) -> M8 {
        F8::eq(self, b)
    }
    #[inline(always)]
    fn select(m: M8, a: Self, b: Self) -> Self {
        F8::select(m, a, b)
    }
    #[inline(always)]
    fn each(self, f: impl Fn(f32) -> f32) -> Self {
        F8::load(&self.store().map(f))
    }
}
