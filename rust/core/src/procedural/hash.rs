//! Blender's hash functions, bit for bit: Bob Jenkins' lookup3 (`hashword`) on 1–4
//! 32-bit words, and the float wrappers Cycles builds on it
//! (Cycles `util/hash.h`: `hash_uint*`, `hash_float*_to_float`, `hash_float*_to_float{2,3,4}`).
//!
//! Floats are hashed by their bit pattern, so `-0.0` and `0.0` hash differently, as in
//! Cycles. Every function is `const`, so seeds and offsets derived from them are
//! compile-time constants.

/// lookup3's `mix(a, b, c)` (http://burtleburtle.net/bob/c/lookup3.c).
#[inline(always)]
const fn mix(mut a: u32, mut b: u32, mut c: u32) -> (u32, u32, u32) {
    a = a.wrapping_sub(c);
    a ^= c.rotate_left(4);
    c = c.wrapping_add(b);
    b = b.wrapping_sub(a);
    b ^= a.rotate_left(6);
    a = a.wrapping_add(c);
    c = c.wrapping_sub(b);
    c ^= b.rotate_left(8);
    b = b.wrapping_add(a);
    a = a.wrapping_sub(c);
    a ^= c.rotate_left(16);
    c = c.wrapping_add(b);
    b = b.wrapping_sub(a);
    b ^= a.rotate_left(19);
    a = a.wrapping_add(c);
    c = c.wrapping_sub(b);
    c ^= b.rotate_left(4);
    b = b.wrapping_add(a);
    (a, b, c)
}

/// lookup3's `final(a, b, c)`; returns `c`, the only word Cycles keeps.
#[inline(always)]
const fn finalize(mut a: u32, mut b: u32, mut c: u32) -> u32 {
    c ^= b;
    c = c.wrapping_sub(b.rotate_left(14));
    a ^= c;
    a = a.wrapping_sub(c.rotate_left(11));
    b ^= a;
    b = b.wrapping_sub(a.rotate_left(25));
    c ^= b;
    c = c.wrapping_sub(b.rotate_left(16));
    a ^= c;
    a = a.wrapping_sub(c.rotate_left(4));
    b ^= a;
    b = b.wrapping_sub(a.rotate_left(14));
    c ^= b;
    c = c.wrapping_sub(b.rotate_left(24));
    c
}

/// lookup3's `hashword` initial state for `n` words: `0xdeadbeef + (n << 2) + initval`;
/// Cycles uses `initval` 13.
const fn seed(n: u32) -> u32 {
    0xdeadbeefu32.wrapping_add(n << 2).wrapping_add(13)
}

/// Cycles `hash_uint`.
#[inline]
pub const fn hash_uint(kx: u32) -> u32 {
    let s = seed(1);
    finalize(s.wrapping_add(kx), s, s)
}

/// Cycles `hash_uint2`.
#[inline]
pub const fn hash_uint2(kx: u32, ky: u32) -> u32 {
    let s = seed(2);
    finalize(s.wrapping_add(kx), s.wrapping_add(ky), s)
}

/// Cycles `hash_uint3`.
#[inline]
pub const fn hash_uint3(kx: u32, ky: u32, kz: u32) -> u32 {
    let s = seed(3);
    finalize(s.wrapping_add(kx), s.wrapping_add(ky), s.wrapping_add(kz))
}

/// Cycles `hash_uint4`: three words are mixed, then the fourth goes through `final`.
#[inline]
pub const fn hash_uint4(kx: u32, ky: u32, kz: u32, kw: u32) -> u32 {
    let s = seed(4);
    let (a, b, c) = mix(s.wrapping_add(kx), s.wrapping_add(ky), s.wrapping_add(kz));
    finalize(a.wrapping_add(kw), b, c)
}

/// Cycles `uint_to_float_incl`: `[0, 2^32-1] -> [0, 1]`. `(float)0xFFFFFFFFu` rounds to
/// 2^32, so the factor is exactly 2^-32 and the largest hashes round up to 1.0.
#[inline]
pub const fn uint_to_float_incl(n: u32) -> f32 {
    n as f32 * (1.0 / 4294967296.0)
}

/// Cycles `hash_uint_to_float`.
#[inline]
pub const fn hash_uint_to_float(kx: u32) -> f32 {
    uint_to_float_incl(hash_uint(kx))
}

/// Cycles `hash_uint2_to_float`.
#[inline]
pub const fn hash_uint2_to_float(kx: u32, ky: u32) -> f32 {
    uint_to_float_incl(hash_uint2(kx, ky))
}

/// Cycles `hash_uint3_to_float`.
#[inline]
pub const fn hash_uint3_to_float(kx: u32, ky: u32, kz: u32) -> f32 {
    uint_to_float_incl(hash_uint3(kx, ky, kz))
}

/// Cycles `hash_uint4_to_float`.
#[inline]
pub const fn hash_uint4_to_float(kx: u32, ky: u32, kz: u32, kw: u32) -> f32 {
    uint_to_float_incl(hash_uint4(kx, ky, kz, kw))
}

/// Cycles `hash_float_to_float`: the float's bits through `hash_uint`, in `[0, 1]`.
#[inline]
pub const fn hash_float_to_float(k: f32) -> f32 {
    hash_uint_to_float(k.to_bits())
}

/// Cycles `hash_float2_to_float`.
#[inline]
pub const fn hash_float2_to_float(x: f32, y: f32) -> f32 {
    hash_uint2_to_float(x.to_bits(), y.to_bits())
}

/// Cycles `hash_float3_to_float`.
#[inline]
pub const fn hash_float3_to_float(x: f32, y: f32, z: f32) -> f32 {
    hash_uint3_to_float(x.to_bits(), y.to_bits(), z.to_bits())
}

/// Cycles `hash_float4_to_float`.
#[inline]
pub const fn hash_float4_to_float(x: f32, y: f32, z: f32, w: f32) -> f32 {
    hash_uint4_to_float(x.to_bits(), y.to_bits(), z.to_bits(), w.to_bits())
}

/// Cycles `hash_float2_to_float2`: the second component appends a third word 1.0.
#[inline]
pub const fn hash_float2_to_float2(x: f32, y: f32) -> [f32; 2] {
    [hash_float2_to_float(x, y), hash_float3_to_float(x, y, 1.0)]
}

/// Cycles `hash_float3_to_float3`: the second and third components append 1.0 and 2.0.
#[inline]
pub const fn hash_float3_to_float3(x: f32, y: f32, z: f32) -> [f32; 3] {
    [hash_float3_to_float(x, y, z), hash_float4_to_float(x, y, z, 1.0), hash_float4_to_float(x, y, z, 2.0)]
}

/// Cycles `hash_float4_to_float4`: the other components hash rotations of the input.
#[inline]
pub const fn hash_float4_to_float4(x: f32, y: f32, z: f32, w: f32) -> [f32; 4] {
    [
        hash_float4_to_float(x, y, z, w),
        hash_float4_to_float(w, x, y, z),
        hash_float4_to_float(z, w, x, y),
        hash_float4_to_float(y, z, w, x),
    ]
}

/// Cycles `hash_float_to_float3`.
#[inline]
pub const fn hash_float_to_float3(k: f32) -> [f32; 3] {
    [hash_float_to_float(k), hash_float2_to_float(k, 1.0), hash_float2_to_float(k, 2.0)]
}

/// Cycles `hash_float2_to_float3`.
#[inline]
pub const fn hash_float2_to_float3(x: f32, y: f32) -> [f32; 3] {
    [hash_float2_to_float(x, y), hash_float3_to_float(x, y, 1.0), hash_float3_to_float(x, y, 2.0)]
}

/// Cycles `hash_float4_to_float3`: the other components hash permutations of the input.
#[inline]
pub const fn hash_float4_to_float3(x: f32, y: f32, z: f32, w: f32) -> [f32; 3] {
    [hash_float4_to_float(x, y, z, w), hash_float4_to_float(z, x, w, y), hash_float4_to_float(w, z, y, x)]
}

#[cfg(test)]
mod tests {
    use super::*;

    /// lookup3's `hashlittle` for arbitrary byte strings, built on the same `mix` and
    /// `final` as the Cycles functions, so the published vectors test those two.
    fn hashlittle(key: &[u8], initval: u32) -> u32 {
        let init = 0xdeadbeefu32.wrapping_add(key.len() as u32).wrapping_add(initval);
        let (mut a, mut b, mut c) = (init, init, init);
        let word = |s: &[u8]| {
            let mut w = [0u8; 4];
            w[..s.len()].copy_from_slice(s);
            u32::from_le_bytes(w)
        };
        let mut k = key;
        while k.len() > 12 {
            a = a.wrapping_add(word(&k[0..4]));
            b = b.wrapping_add(word(&k[4..8]));
            c = c.wrapping_add(word(&k[8..12]));
            (a, b, c) = mix(a, b, c);
            k = &k[12..];
        }
        if k.is_empty() {
            return c;
        }
        a = a.wrapping_add(word(&k[..k.len().min(4)]));
        if k.len() > 4 {
            b = b.wrapping_add(word(&k[4..k.len().min(8)]));
        }
        if k.len() > 8 {
            c = c.wrapping_add(word(&k[8..]));
        }
        finalize(a, b, c)
    }

    #[test]
    fn lookup3_published_vectors() {
        // From lookup3.c's driver5(): hashlittle("", 0, 0) = deadbeef,
        // "Four score and seven years ago" with initval 0 -> 17770551, 1 -> cd628161.
        assert_eq!(hashlittle(b"", 0), 0xdeadbeef);
        assert_eq!(hashlittle(b"Four score and seven years ago", 0), 0x17770551);
        assert_eq!(hashlittle(b"Four score and seven years ago", 1), 0xcd628161);
    }

    #[test]
    fn hash_uint_is_lookup3_of_the_little_endian_words() {
        // lookup3: hashword() equals hashlittle() of the same words on little-endian
        // machines; Cycles' hash_uint{,2,3,4} are hashword(k, n, 13).
        let mut x = 0x1234_5678u32;
        for _ in 0..200 {
            x = x.wrapping_mul(747796405).wrapping_add(2891336453);
            let k = [x, x.rotate_left(7) ^ 0x9e37_79b9, x.wrapping_mul(3), !x];
            let bytes: Vec<u8> = k.iter().flat_map(|w| w.to_le_bytes()).collect();
            assert_eq!(hash_uint(k[0]), hashlittle(&bytes[..4], 13));
            assert_eq!(hash_uint2(k[0], k[1]), hashlittle(&bytes[..8], 13));
            assert_eq!(hash_uint3(k[0], k[1], k[2]), hashlittle(&bytes[..12], 13));
            assert_eq!(hash_uint4(k[0], k[1], k[2], k[3]), hashlittle(&bytes[..16], 13));
        }
    }

    #[test]
    fn floats_hash_their_bits_into_the_closed_unit_interval() {
        assert_eq!(uint_to_float_incl(0), 0.0);
        assert_eq!(uint_to_float_incl(u32::MAX), 1.0);
        assert_ne!(hash_float_to_float(0.0), hash_float_to_float(-0.0));
        for v in [f32::NAN, f32::INFINITY, f32::NEG_INFINITY, f32::MAX, -1e30, 0.5] {
            let h = hash_float4_to_float3(v, 1.0, v, 2.0);
            assert!(h.iter().all(|c| (0.0..=1.0).contains(c)));
        }
    }
}
