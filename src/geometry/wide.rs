//! SIMD lanes for the geometry's box and triangle tests: [`Wide`], what a slab test needs (the
//! tree's nodes and the small-scene scan's pack boxes), and [`WideTest`], what the watertight
//! triangle test needs besides (the scan's packs). Each lane is rounded as the scalar operation,
//! so a wide test answers as the scalar one, bit for bit.
//!
//! Implementations: one AVX-512 vector of sixteen lanes ([`x86::Z16`]) and one AVX2 vector of
//! eight ([`x86::Y8`], the crate's [`crate::simd::F8`], which the lockstep path tracer's lanes use
//! too), whose functions are inlined into `#[target_feature]` callers picked at
//! run time ([`supported`]); and four lanes of glam's `Vec4` ([`Q4`]: SSE2 on x86-64, NEON on
//! aarch64), which every CPU runs.

use glam::Vec4;
use std::ops::{BitAnd, BitOr, Not};

/// A SIMD extension the scan and the tree's node test are compiled for (none elsewhere than on
/// x86-64).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum Isa {
    #[cfg(target_arch = "x86_64")]
    Avx512,
    #[cfg(target_arch = "x86_64")]
    Avx2,
}

/// The SIMD extensions of this CPU that [`Isa`] names, widest first.
pub(super) fn supported() -> Vec<Isa> {
    #[allow(unused_mut)]
    let mut isa = Vec::new();
    #[cfg(target_arch = "x86_64")]
    {
        if std::arch::is_x86_feature_detected!("avx512f") {
            isa.push(Isa::Avx512);
        }
        if std::arch::is_x86_feature_detected!("avx2") {
            isa.push(Isa::Avx2);
        }
    }
    isa
}

/// A lane mask of [`Wide`] vectors: a bit per lane (AVX-512's mask registers, [`Q4`]) or a
/// vector of all-ones and all-zeros lanes (AVX2, whose blends and logic take those without a
/// round trip through integer bits).
pub(super) trait Mask:
    Copy + BitAnd<Output = Self> + BitOr<Output = Self> + Not<Output = Self>
{
    /// The mask with lane `i` set where bit `i` of `bits` is.
    fn from_bits(bits: u32) -> Self;
    /// Bit `i` set where lane `i` is.
    fn bits(self) -> u32;
}

/// Masks that are bits already.
impl Mask for u32 {
    #[inline(always)]
    fn from_bits(bits: u32) -> Self {
        bits
    }
    #[inline(always)]
    fn bits(self) -> u32 {
        self
    }
}

/// [`Self::WIDTH`] `f32` lanes with what a slab test needs (comparisons give a mask, false on
/// NaN as in Rust).
pub(super) trait Wide: Copy {
    type Mask: Mask;
    /// Lanes per vector: sixteen lanes take `16 / WIDTH` steps.
    const WIDTH: usize;
    fn splat(x: f32) -> Self;
    /// Lanes `at..at + WIDTH` of `a`.
    fn load(a: &[f32], at: usize) -> Self;
    /// The lanes into `a[at..at + WIDTH]`.
    fn store_at(self, a: &mut [f32], at: usize);
    fn sub(self, b: Self) -> Self;
    fn mul(self, b: Self) -> Self;
    /// The lane-wise maximum (`b` where either is NaN, as `maxps` and glam's `max`).
    fn max(self, b: Self) -> Self;
    /// The lane-wise minimum (`b` where either is NaN, as `minps` and glam's `min`).
    fn min(self, b: Self) -> Self;
    fn le(self, b: Self) -> Self::Mask;
}

/// What the watertight triangle test needs beyond [`Wide`] ([`super::triangle_pack`]).
pub(super) trait WideTest: Wide {
    fn add(self, b: Self) -> Self;
    fn div(self, b: Self) -> Self;
    fn lt(self, b: Self) -> Self::Mask;
    fn eq(self, b: Self) -> Self::Mask;
    /// The lanes where the sign bits of `a`, `b` and `c` are not all equal.
    fn signs_differ(a: Self, b: Self, c: Self) -> Self::Mask;
    /// The lanes, in the first `WIDTH` elements.
    #[inline(always)]
    fn store(self) -> [f32; 16] {
        let mut a = [0.0; 16];
        self.store_at(&mut a, 0);
        a
    }
    #[inline(always)]
    fn lane(self, lane: usize) -> f32 {
        self.store()[lane]
    }
}

/// What the small-scene scan's branch-free closest hit needs beyond [`WideTest`].
pub(super) trait WideClosest: WideTest {
    /// The bits of lanes `at..at + WIDTH` of `a`.
    fn load_bits(a: &[u32], at: usize) -> Self;
    /// `a` in the lanes of `mask`, `b` in the others.
    fn select(mask: Self::Mask, a: Self, b: Self) -> Self;
    /// The least lane (no lane is NaN).
    fn reduce_min(self) -> f32;
}

/// Four lanes of glam's `Vec4`, masks as bits: the baseline every CPU runs.
#[derive(Clone, Copy)]
pub(super) struct Q4(Vec4);

impl Wide for Q4 {
    type Mask = u32;
    const WIDTH: usize = 4;
    #[inline(always)]
    fn splat(x: f32) -> Self {
        Self(Vec4::splat(x))
    }
    #[inline(always)]
    fn load(a: &[f32], at: usize) -> Self {
        Self(Vec4::from_slice(&a[at..at + 4]))
    }
    #[inline(always)]
    fn store_at(self, a: &mut [f32], at: usize) {
        self.0.write_to_slice(&mut a[at..at + 4]);
    }
    #[inline(always)]
    fn sub(self, b: Self) -> Self {
        Self(self.0 - b.0)
    }
    #[inline(always)]
    fn mul(self, b: Self) -> Self {
        Self(self.0 * b.0)
    }
    #[inline(always)]
    fn max(self, b: Self) -> Self {
        Self(self.0.max(b.0))
    }
    #[inline(always)]
    fn min(self, b: Self) -> Self {
        Self(self.0.min(b.0))
    }
    #[inline(always)]
    fn le(self, b: Self) -> u32 {
        self.0.cmple(b.0).bitmask()
    }
}

impl WideTest for Q4 {
    #[inline(always)]
    fn add(self, b: Self) -> Self {
        Self(self.0 + b.0)
    }
    #[inline(always)]
    fn div(self, b: Self) -> Self {
        Self(self.0 / b.0)
    }
    #[inline(always)]
    fn lt(self, b: Self) -> u32 {
        self.0.cmplt(b.0).bitmask()
    }
    #[inline(always)]
    fn eq(self, b: Self) -> u32 {
        self.0.cmpeq(b.0).bitmask()
    }
    #[inline(always)]
    fn signs_differ(a: Self, b: Self, c: Self) -> u32 {
        let (a, b, c) = (
            a.0.is_negative_bitmask(),
            b.0.is_negative_bitmask(),
            c.0.is_negative_bitmask(),
        );
        (a ^ b) | (a ^ c)
    }
}

/// The x86-64 implementations: one AVX-512 vector of sixteen lanes, or one AVX2 vector of eight
/// (sixteen lanes in two steps).
#[cfg(target_arch = "x86_64")]
pub(super) mod x86 {
    use super::{Mask, Wide, WideClosest, WideTest};
    use std::arch::x86_64::*;

    #[derive(Clone, Copy)]
    pub struct Z16(__m512);

    /// Eight lanes in one AVX2 vector: the crate's [`crate::simd::F8`], with its mask.
    pub use crate::simd::{F8 as Y8, M8};

    // SAFETY (every block below): only reached from functions compiled with the extension,
    // called after it was detected on this CPU; loads and stores are of whole vectors within
    // arrays whose bounds the slices check.
    impl Mask for M8 {
        #[inline(always)]
        fn from_bits(bits: u32) -> Self {
            M8::from_bits(bits)
        }
        #[inline(always)]
        fn bits(self) -> u32 {
            M8::bits(self)
        }
    }

    impl Wide for Z16 {
        type Mask = u32;
        const WIDTH: usize = 16;
        #[inline(always)]
        fn splat(x: f32) -> Self {
            Self(unsafe { _mm512_set1_ps(x) })
        }
        #[inline(always)]
        fn load(a: &[f32], at: usize) -> Self {
            Self(unsafe { _mm512_loadu_ps(a[at..at + 16].as_ptr()) })
        }
        #[inline(always)]
        fn store_at(self, a: &mut [f32], at: usize) {
            unsafe { _mm512_storeu_ps(a[at..at + 16].as_mut_ptr(), self.0) };
        }
        #[inline(always)]
        fn sub(self, b: Self) -> Self {
            Self(unsafe { _mm512_sub_ps(self.0, b.0) })
        }
        #[inline(always)]
        fn mul(self, b: Self) -> Self {
            Self(unsafe { _mm512_mul_ps(self.0, b.0) })
        }
        #[inline(always)]
        fn max(self, b: Self) -> Self {
            Self(unsafe { _mm512_max_ps(self.0, b.0) })
        }
        #[inline(always)]
        fn min(self, b: Self) -> Self {
            Self(unsafe { _mm512_min_ps(self.0, b.0) })
        }
        #[inline(always)]
        fn le(self, b: Self) -> u32 {
            unsafe { _mm512_cmp_ps_mask::<_CMP_LE_OQ>(self.0, b.0) as u32 }
        }
    }

    impl WideTest for Z16 {
        #[inline(always)]
        fn add(self, b: Self) -> Self {
            Self(unsafe { _mm512_add_ps(self.0, b.0) })
        }
        #[inline(always)]
        fn div(self, b: Self) -> Self {
            Self(unsafe { _mm512_div_ps(self.0, b.0) })
        }
        #[inline(always)]
        fn lt(self, b: Self) -> u32 {
            unsafe { _mm512_cmp_ps_mask::<_CMP_LT_OQ>(self.0, b.0) as u32 }
        }
        #[inline(always)]
        fn eq(self, b: Self) -> u32 {
            unsafe { _mm512_cmp_ps_mask::<_CMP_EQ_OQ>(self.0, b.0) as u32 }
        }
        #[inline(always)]
        fn signs_differ(a: Self, b: Self, c: Self) -> u32 {
            unsafe {
                let (a, b, c) = (
                    _mm512_castps_si512(a.0),
                    _mm512_castps_si512(b.0),
                    _mm512_castps_si512(c.0),
                );
                let x = _mm512_or_si512(_mm512_xor_si512(a, b), _mm512_xor_si512(a, c));
                _mm512_cmplt_epi32_mask(x, _mm512_setzero_si512()) as u32
            }
        }
    }

    impl WideClosest for Z16 {
        #[inline(always)]
        fn load_bits(a: &[u32], at: usize) -> Self {
            Self(unsafe { _mm512_castsi512_ps(_mm512_loadu_si512(a[at..at + 16].as_ptr().cast())) })
        }
        #[inline(always)]
        fn select(mask: u32, a: Self, b: Self) -> Self {
            Self(unsafe { _mm512_mask_blend_ps(mask as u16, b.0, a.0) })
        }
        #[inline(always)]
        fn reduce_min(self) -> f32 {
            unsafe { _mm512_reduce_min_ps(self.0) }
        }
    }

    impl Wide for Y8 {
        type Mask = M8;
        const WIDTH: usize = 8;
        #[inline(always)]
        fn splat(x: f32) -> Self {
            Y8::splat(x)
        }
        #[inline(always)]
        fn load(a: &[f32], at: usize) -> Self {
            Y8::load(eight(&a[at..at + 8]))
        }
        #[inline(always)]
        fn store_at(self, a: &mut [f32], at: usize) {
            self.store_into((&mut a[at..at + 8]).try_into().expect("eight lanes"));
        }
        #[inline(always)]
        fn sub(self, b: Self) -> Self {
            self - b
        }
        #[inline(always)]
        fn mul(self, b: Self) -> Self {
            self * b
        }
        #[inline(always)]
        fn max(self, b: Self) -> Self {
            Y8::max(self, b)
        }
        #[inline(always)]
        fn min(self, b: Self) -> Self {
            Y8::min(self, b)
        }
        #[inline(always)]
        fn le(self, b: Self) -> M8 {
            Y8::le(self, b)
        }
    }

    impl WideTest for Y8 {
        #[inline(always)]
        fn add(self, b: Self) -> Self {
            self + b
        }
        #[inline(always)]
        fn div(self, b: Self) -> Self {
            self / b
        }
        #[inline(always)]
        fn lt(self, b: Self) -> M8 {
            Y8::lt(self, b)
        }
        #[inline(always)]
        fn eq(self, b: Self) -> M8 {
            Y8::eq(self, b)
        }
        #[inline(always)]
        fn signs_differ(a: Self, b: Self, c: Self) -> M8 {
            Y8::signs_differ(a, b, c)
        }
    }

    impl WideClosest for Y8 {
        #[inline(always)]
        fn load_bits(a: &[u32], at: usize) -> Self {
            Y8::load_bits(eight(&a[at..at + 8]))
        }
        #[inline(always)]
        fn select(mask: M8, a: Self, b: Self) -> Self {
            Y8::select(mask, a, b)
        }
        #[inline(always)]
        fn reduce_min(self) -> f32 {
            Y8::reduce_min(self)
        }
    }

    /// A slice of eight as an array.
    #[inline(always)]
    fn eight<T>(a: &[T]) -> &[T; 8] {
        a.try_into().expect("eight lanes")
    }
}
