"""Sample generators for the distribution ray tracer.

Every camera sample is one point of the whole integrand domain (Cook, Porter, Carpenter 1984):
pixel position, lens position, time, then per bounce a light-sample position, a light choice,
a glossy perturbation and a Fresnel choice.  The domain is cut into **dimension pairs**; the
integrator asks for pair ``dim`` of sample ``index`` of pixel ``pixel``:

    sample_2d(sampler, seed, pixel, index, spp, dim) -> (u, v) in [0, 1)^2
    sample_1d(sampler, seed, pixel, index, spp, dim) -> u in [0, 1)

Both are pure functions of their arguments (no RNG state), so a render is bit-identical whatever
the thread count or the order in which pixels and samples are evaluated.  All values are
multiples of 2^-24, hence exactly representable in float32 and strictly below 1.

Which pair feeds which decision (pixel, lens, time, lights, BSDF, choices per bounce) is owned by
``dimensions.py``; the samplers only know that pairs DIM_PIXEL and DIM_LENS form one 4D Sobol' point.

Samplers
--------
INDEPENDENT
    Hashed uniform random numbers (a 32-bit integer hash of (seed, pixel, index, dim)); error
    falls as spp^-1/2.  ``index`` may be any non-negative integer, so the sample count can be
    extended indefinitely.
STRATIFIED
    Jittered sampling (Cook 1986, "Stochastic sampling in computer graphics", ACM TOG 5(1)): an
    nx x ny grid with nx*ny = spp (the most square factorisation; a prime spp degenerates to
    1 x spp) and one uniformly jittered sample per cell.  The pairing of cells across dimension
    pairs is decorrelated by permuting the sample index with Kensler's hash ``permute``, seeded per
    (seed, pixel, pair), as in pbrt's StratifiedSampler.
CMJ
    Correlated multi-jittered sampling (A. Kensler, "Correlated Multi-Jittered Sampling", Pixar
    Technical Memo 13-01, 2013), the final listing with arbitrary N: a jittered grid that is also a
    Latin hypercube (one sample per 1D row and column stratum), permuted per (seed, pixel, pair).
SOBOL
    Owen-scrambled Sobol' points with the hash-based nested uniform scrambling of B. Burley,
    "Practical Hash-based Owen Scrambling", JCGT 9(4), 2020, using the improved Laine-Karras style
    hash of N. Vegdahl ("Building a better LK hash", 2021, also used by Cycles).  Pairs 0 and 1
    (pixel and lens) are one 4D Owen-scrambled Sobol' point (dims 0..3, shared shuffled index), so
    depth of field, where pixel and lens couple, is stratified in 4D.  Every further pair is a
    padded 2D Owen-scrambled Sobol' point (dims 0, 1) with its own index shuffle seeded by
    hash(seed, pixel, pair), which decorrelates the pairs.  For spp = 2^m the 2^m points of pair 0
    and of each padded pair form a (0, m, 2)-net; the index shuffle maps every aligned block of
    2^m indices onto an aligned block, so passes of 2^k samples stay nets too.  The first Sobol'
    point is never skipped and no Cranley-Patterson shift is applied (both would break the net).

Sample index beyond ``spp``
---------------------------
* INDEPENDENT and SOBOL are sequences: ``index >= spp`` simply continues them (Sobol' stays
  well stratified at every power-of-two prefix), so ``spp`` is ignored by them.
* STRATIFIED and CMJ are point *sets* of size ``spp``.  ``index >= spp`` is allowed and starts a
  fresh, independently permuted set for every block ``index // spp``: rendering 2*spp samples
  yields two stratified sets of spp samples each (valid, but not one stratified set of 2*spp).
  For progressive rendering with these samplers pass the final total ``spp``.

All integers are handled as int64 holding unsigned 32-bit values (explicit ``& 0xFFFFFFFF``), so
the same code gives identical results when run as plain Python (``.py_func``) and under numba.
"""
from __future__ import annotations

import math

import numpy as np
from llvmlite import ir
from numba import njit, types
from numba.extending import intrinsic

from .dimensions import DIM_LENS, lens_dim, pixel_dim
from .features import B_CMJ, B_SOBOL, B_STRATIFIED, F_SAMPLERS
from .jit import INLINE_JIT, JIT, SHADING_JIT

# --------------------------------------------------------------------------- public constants
INDEPENDENT, STRATIFIED, CMJ, SOBOL = 0, 1, 2, 3
SAMPLER_NAMES = {'independent': INDEPENDENT, 'stratified': STRATIFIED, 'cmj': CMJ, 'sobol': SOBOL}

_M32 = 0xFFFFFFFF
# The hashing and scrambling helpers are inlined into the public functions at numba IR level
# (INLINE_JIT): as separate LLVM functions a Sobol' 2D sample took 45 ns, inlined 29 ns.
_INV_2_24 = 1.0 / 16777216.0
_ONE_MINUS = 1.0 - _INV_2_24       # largest float32 below 1: clamp so that float32(u) < 1 too


# --------------------------------------------------------------------------- integer hashing
@njit(**INLINE_JIT)
def mix32(x):
    """Chris Wellons' 'lowbias32' 32-bit integer finaliser (full avalanche, bias ~0.17)."""
    x &= _M32
    x ^= x >> 16
    x = (x * 0x7FEB352D) & _M32
    x ^= x >> 15
    x = (x * 0x846CA68B) & _M32
    x ^= x >> 16
    return x


@njit(**INLINE_JIT)
def hash_combine(h, v):
    """Fold the (up to 64-bit, non-negative) integer ``v`` into the 32-bit hash ``h``."""
    v = np.int64(v)
    h = mix32((h & _M32) ^ (v & _M32))
    hi = (v >> 32) & _M32
    if hi != 0:
        h = mix32(h ^ hi ^ 0x9E3779B9)
    return h


@njit(**INLINE_JIT)
def hash3(a, b, c):
    """32-bit hash of three integers."""
    return hash_combine(hash_combine(mix32(np.int64(a) ^ 0x2545F491), b), c)


@njit(**INLINE_JIT)
def to_unit(x):
    """Top 24 bits of a 32-bit integer as a float in [0, 1), exact in float32."""
    return ((x & _M32) >> 8) * _INV_2_24


# --------------------------------------------------------------------------- Kensler 2013
@njit(**INLINE_JIT)
def permute(i, l, p):
    """Kensler 2013, listing 3: a pseudo-random permutation of [0, l) indexed by pattern ``p``,
    evaluated at ``i`` (hash on the next power of two with cycle walking)."""
    i &= _M32
    p &= _M32
    w = l - 1
    w |= w >> 1
    w |= w >> 2
    w |= w >> 4
    w |= w >> 8
    w |= w >> 16
    while True:
        i ^= p
        i = (i * 0xE170893D) & _M32
        i ^= p >> 16
        i ^= (i & w) >> 4
        i ^= p >> 8
        i = (i * 0x0929EB3F) & _M32
        i ^= p >> 23
        i ^= (i & w) >> 1
        i = (i * (1 | (p >> 27))) & _M32
        i = (i * 0x6935FA69) & _M32
        i ^= (i & w) >> 11
        i = (i * 0x74DCB303) & _M32
        i ^= (i & w) >> 2
        i = (i * 0x9E501CC3) & _M32
        i ^= (i & w) >> 2
        i = (i * 0xC860A3DF) & _M32
        i &= w
        i ^= i >> 5
        if i < l:
            break
    return (i + p) % l


@njit(**INLINE_JIT)
def randfloat(i, p):
    """Kensler 2013, listing 4: hashed float in [0, 1) for index ``i`` and pattern ``p``
    (returned with 24 bits so that it stays < 1 in float32)."""
    i &= _M32
    p &= _M32
    i ^= p
    i ^= i >> 17
    i ^= i >> 10
    i = (i * 0xB36534E5) & _M32
    i ^= i >> 12
    i ^= i >> 21
    i = (i * 0x93FC4795) & _M32
    i ^= 0xDF6E307F
    i ^= i >> 17
    i = (i * (1 | (p >> 18))) & _M32
    return to_unit(i)


@njit(**INLINE_JIT)
def cmj(s, n_samples, p):
    """Kensler 2013, listing 6 (final CMJ, any N, aspect 1): sample ``s`` of ``n_samples`` of
    pattern ``p``.  One sample per cell of the m x n grid (m = floor(sqrt(N)), n = ceil(N/m)) and
    per each of the N row and column strata (Latin hypercube)."""
    p &= _M32
    m = np.int64(math.sqrt(n_samples))
    while m * m > n_samples:          # guard against sqrt rounding
        m -= 1
    while (m + 1) * (m + 1) <= n_samples:
        m += 1
    n = (n_samples + m - 1) // m
    s = permute(s, n_samples, p * 0x51633E2D)
    sx = permute(s % m, m, p * 0x68BC21EB)
    sy = permute(s // m, n, p * 0x02E5BE93)
    jx = randfloat(s, p * 0x967A889B)
    jy = randfloat(s, p * 0x368CC8B7)
    x = (sx + (sy + jx) / n) / m
    y = (s + jy) / n_samples
    return min(x, _ONE_MINUS), min(y, _ONE_MINUS)



# --------------------------------------------------------------------------- Sobol' + Burley 2020
def _sobol_directions(n_dims: int = 4) -> np.ndarray:
    """32-bit Sobol' direction numbers, dims 0 (van der Corput) .. n_dims-1, from the
    Joe & Kuo (2008) 'new-joe-kuo-6.21201' primitive polynomials and initial m_k."""
    # (s, a, m_1..m_s) for Joe-Kuo dimensions 2, 3, 4, 5, 6
    table = [(1, 0, (1,)), (2, 1, (1, 3)), (3, 1, (1, 3, 1)), (3, 2, (1, 1, 1)), (4, 1, (1, 1, 3, 3))]
    if n_dims - 1 > len(table):
        raise ValueError('direction numbers only tabulated for %d dims' % (len(table) + 1))
    v = np.zeros((n_dims, 32), dtype=np.int64)
    for k in range(32):
        v[0, k] = 1 << (31 - k)
    for d in range(1, n_dims):
        s, a, m_init = table[d - 1]
        m = list(m_init)
        for k in range(s, 32):           # m_{k+1} in 1-based terms
            new = m[k - s] ^ (m[k - s] << s)
            for j in range(1, s):
                if (a >> (s - 1 - j)) & 1:
                    new ^= m[k - j] << j
            m.append(new)
        for k in range(32):
            v[d, k] = m[k] << (31 - k)
    return v


def _byte_tables(v: np.ndarray) -> np.ndarray:
    """T[d, b, j] = XOR of the direction numbers selected by the bits of byte value j at byte
    position b, so that a Sobol' value is four table look-ups instead of 32 conditional XORs."""
    t = np.zeros((v.shape[0], 4, 256), dtype=np.int64)
    for d in range(v.shape[0]):
        for b in range(4):
            for j in range(256):
                x = 0
                for k in range(8):
                    if (j >> k) & 1:
                        x ^= int(v[d, 8 * b + k])
                t[d, b, j] = x
    return t


SOBOL_DIRECTIONS = _sobol_directions(4)
SOBOL_BYTES = _byte_tables(SOBOL_DIRECTIONS)
SOBOL_BYTES_U32 = SOBOL_BYTES.astype(np.uint32)


@njit(**INLINE_JIT)
def sobol(index, dim):
    """Unscrambled 32-bit Sobol' value of ``index`` in dimension ``dim`` (0..3), natural order:
    the XOR of the direction numbers of the set bits of ``index`` (generator-matrix product).  The
    table is uint32 (16 KiB: half the cache lines of int64 entries)."""
    index &= _M32
    t = SOBOL_BYTES_U32
    return np.int64(t[dim, 0, index & 0xFF] ^ t[dim, 1, (index >> 8) & 0xFF]
                    ^ t[dim, 2, (index >> 16) & 0xFF] ^ t[dim, 3, index >> 24])


@intrinsic
def _bitreverse32(typingctx, x):
    """LLVM's `llvm.bitreverse.i32` on the low 32 bits of an int64 (zero-extended back): a byte swap
    and three mask-and-shift steps on x86-64 instead of five (or a GFNI affine op where available)."""
    sig = types.int64(types.int64)

    def codegen(context, builder, signature, args):
        i32 = ir.IntType(32)
        fn = builder.module.declare_intrinsic('llvm.bitreverse', [i32])
        return builder.zext(builder.call(fn, [builder.trunc(args[0], i32)]), ir.IntType(64))
    return sig, codegen


@njit(**INLINE_JIT)
def reverse_bits(x):
    """Reverse the 32 bits of ``x``."""
    return _bitreverse32(np.int64(x))


@njit(**INLINE_JIT)
def laine_karras_permutation(x, seed):
    """Owen-scrambling hash on bit-reversed integers (Burley 2020, listing 2): every output bit
    depends only on the same and lower input bits.  Constants from Vegdahl 2021's improved hash."""
    x &= _M32
    seed &= _M32
    x ^= (x * 0x3D20ADEA) & _M32
    x = (x + seed) & _M32
    x = (x * ((seed >> 16) | 1)) & _M32
    x ^= (x * 0x05526C56) & _M32
    x ^= (x * 0x53A22864) & _M32
    return x


@njit(**INLINE_JIT)
def nested_uniform_scramble(x, seed):
    """Owen (nested uniform) scramble of a 32-bit fixed-point value (Burley 2020, listing 3)."""
    return reverse_bits(laine_karras_permutation(reverse_bits(x), seed))


@njit(**INLINE_JIT)
def _sobol_owen(index, seed, d):
    """Dim d of the Owen-scrambled Sobol' point at shuffled ``index``: `nested_uniform_scramble` of
    `sobol(index, d)`.  Dim 0's generator matrix is the bit reversal, which the scramble's first step
    undoes: reverse(LK(index)), no table look-ups."""
    if d == 0:
        return reverse_bits(laine_karras_permutation(index, hash_combine(seed, 0)))
    return nested_uniform_scramble(sobol(index, d), hash_combine(seed, d))


@njit(**INLINE_JIT)
def _sobol_owen_2d(index, seed, d0):
    """Dims d0, d0+1 of the Owen-scrambled Sobol' point at shuffled ``index``."""
    return to_unit(_sobol_owen(index, seed, d0)), to_unit(_sobol_owen(index, seed, d0 + 1))


@njit(**INLINE_JIT)
def sobol_sample_4d(seed, pixel, index):
    """Pairs 0 and 1 (pixel, lens) of sample ``index`` at once: one 4D point, so one hash and one
    index shuffle instead of two of each (the values of two `sobol_sample_2d` calls)."""
    pseed = hash3(seed, pixel, 0x5EED0001)
    shuffled = nested_uniform_scramble(index, pseed)
    a, b = _sobol_owen_2d(shuffled, pseed, 0)
    c, d = _sobol_owen_2d(shuffled, pseed, 2)
    return a, b, c, d


@njit(**INLINE_JIT)
def sobol_sample_2d(seed, pixel, index, dim):
    """Pair ``dim`` of the Owen-scrambled Sobol' sample ``index``: pairs 0, 1 = one 4D point,
    later pairs = padded 2D points with a per-(pixel, pair) index shuffle (Burley 2020, sec. 4-5)."""
    if dim <= DIM_LENS:
        pseed = hash3(seed, pixel, 0x5EED0001)
        shuffled = nested_uniform_scramble(index, pseed)
        return _sobol_owen_2d(shuffled, pseed, 2 * dim)
    pseed = hash3(seed, pixel, dim)
    shuffled = nested_uniform_scramble(index, pseed)
    return _sobol_owen_2d(shuffled, pseed, 0)


# --------------------------------------------------------------------------- Sobol' for a packet (SIMD)
# The same values as `sobol_sample_4d` / `sobol_sample_2d`, for the lanes of a packet at once: the
# hashing and scrambling run in loops over the lanes on uint32 values, which LLVM vectorises (one
# AVX2/AVX-512 instruction per operation for 8-16 lanes); only the generator-matrix products (four
# table look-ups per dimension) stay scalar.  Exact for pixel and index < 2^32 (the render limits:
# 2^28 pixels, 2^20 samples), where `hash_combine` takes its one-word path.
@intrinsic
def _bitreverse_u32(typingctx, x):
    sig = types.uint32(types.uint32)

    def codegen(context, builder, signature, args):
        fn = builder.module.declare_intrinsic('llvm.bitreverse', [ir.IntType(32)])
        return builder.call(fn, [args[0]])
    return sig, codegen


@njit(**INLINE_JIT)
def _mix32_u(x):
    x = np.uint32(x ^ (x >> np.uint32(16)))
    x = np.uint32(x * np.uint32(0x7FEB352D))
    x = np.uint32(x ^ (x >> np.uint32(15)))
    x = np.uint32(x * np.uint32(0x846CA68B))
    return np.uint32(x ^ (x >> np.uint32(16)))


@njit(**INLINE_JIT)
def _owen_u(x, seed):
    """`nested_uniform_scramble` on uint32."""
    x = _bitreverse_u32(x)
    x = np.uint32(x ^ np.uint32(x * np.uint32(0x3D20ADEA)))
    x = np.uint32(x + seed)
    x = np.uint32(x * np.uint32((seed >> np.uint32(16)) | np.uint32(1)))
    x = np.uint32(x ^ np.uint32(x * np.uint32(0x05526C56)))
    x = np.uint32(x ^ np.uint32(x * np.uint32(0x53A22864)))
    return _bitreverse_u32(x)


@njit(**INLINE_JIT)
def _sobol_u(tables, index, dim):
    return np.uint32(tables[dim, 0, index & np.uint32(0xFF)] ^ tables[dim, 1, (index >> np.uint32(8)) & np.uint32(0xFF)]
                     ^ tables[dim, 2, (index >> np.uint32(16)) & np.uint32(0xFF)]
                     ^ tables[dim, 3, index >> np.uint32(24)])


PIXEL_LENS_TAG = 0x5EED0001      # hash tag of the 4D point of pairs DIM_PIXEL and DIM_LENS


@njit(**SHADING_JIT)
def sobol_packet(seed, pair, pixel, index, n, n_dims, work, out):
    """Owen-scrambled Sobol' samples (pixel[j], index[j]) for the lanes j < n of a packet:
    out[d, j] for d < n_dims, bit for bit the scalar sampler's values:

    * pair DIM_PIXEL, n_dims 4: `sample_pixel_lens(SOBOL, ...)` (pixel and lens: one 4D point);
      n_dims 2: `sample_2d(SOBOL, ..., DIM_PIXEL)`;
    * a later pair, n_dims 2: `sample_2d(SOBOL, ..., pair)`; n_dims 1: `sample_1d(SOBOL, ..., pair)`.

    pixel, index: uint32 (PACKET,); work: uint32 (6, PACKET) scratch; out: float64 (>= n_dims, PACKET)."""
    tables = SOBOL_BYTES_U32
    tag = np.uint32(PIXEL_LENS_TAG if pair <= DIM_LENS else pair)
    s0 = np.uint32(mix32(np.int64(seed) ^ 0x2545F491))
    for j in range(n):                  # vectorised: the point's seed and its shuffled index
        pseed = _mix32_u(np.uint32(_mix32_u(np.uint32(s0 ^ pixel[j])) ^ tag))
        work[0, j] = pseed
        work[1, j] = _owen_u(index[j], pseed)
    for j in range(n):                  # scalar: table look-ups (dim 0 is the bit reversal itself)
        sh = work[1, j]
        for d in range(1, n_dims):
            work[2 + d, j] = _sobol_u(tables, sh, d)
    for j in range(n):                  # vectorised: scramble every dimension (dim 0 from the index)
        work[2, j] = _owen_u(_bitreverse_u32(work[1, j]), _mix32_u(work[0, j]))
    for d in range(1, n_dims):
        for j in range(n):
            work[2 + d, j] = _owen_u(work[2 + d, j], _mix32_u(np.uint32(work[0, j] ^ np.uint32(d))))
    for d in range(n_dims):             # vectorised: to [0, 1) (24 bits, as `to_unit`)
        for j in range(n):
            out[d, j] = np.float64(np.int32(work[2 + d, j] >> np.uint32(8))) * _INV_2_24


# --------------------------------------------------------------------------- other samplers
@njit(**INLINE_JIT)
def independent_sample_2d(seed, pixel, index, dim):
    """Two hashed uniform numbers for (seed, pixel, index, pair)."""
    h = hash_combine(hash3(seed, pixel, index), dim)
    return to_unit(mix32(h ^ 0x68E31DA4)), to_unit(mix32(h ^ 0xB5297A4D))


@njit(**INLINE_JIT)
def _grid_factor(n):
    """Most square factorisation n = nx * ny with nx <= ny; returns nx."""
    nx = np.int64(math.sqrt(n))
    while nx * nx > n:
        nx -= 1
    while (nx + 1) * (nx + 1) <= n:
        nx += 1
    while nx > 1 and n % nx != 0:
        nx -= 1
    return max(nx, 1)


@njit(**INLINE_JIT)
def _pattern(seed, pixel, index, spp, dim):
    """Kensler pattern id of the set that sample ``index`` belongs to, and its index in the set."""
    rnd = index // spp
    p = hash3(seed, pixel, dim)
    if rnd != 0:
        p = hash_combine(p, rnd)
    return p, index - rnd * spp


@njit(**INLINE_JIT)
def stratified_sample_2d(seed, pixel, index, spp, dim):
    """Jittered nx x ny grid sample; cell order permuted per (seed, pixel, pair)."""
    p, i = _pattern(seed, pixel, index, spp, dim)
    nx = _grid_factor(spp)
    ny = spp // nx
    s = permute(i, spp, p)
    x = (s % nx + randfloat(s, p * 0xA399D265)) / nx
    y = (s // nx + randfloat(s, p * 0x711AD6A5)) / ny
    return min(x, _ONE_MINUS), min(y, _ONE_MINUS)


# --------------------------------------------------------------------------- public API
@njit(**JIT)
def sample_2d(sampler, seed, pixel, index, spp, dim):
    """Dimension pair ``dim`` of sample ``index`` (of ``spp``) of pixel ``pixel``: (u, v) in [0,1)^2.

    ``sampler`` is one of INDEPENDENT, STRATIFIED, CMJ, SOBOL; ``seed`` a 32-bit seed.
    Deterministic: a pure function of the arguments."""
    seed = np.int64(seed) & _M32
    pixel = np.int64(pixel)
    index = np.int64(index)
    spp = max(np.int64(spp), 1)
    dim = np.int64(dim)
    # the samplers a kernel can meet (features.F_SAMPLERS): a render's kernel holds its own sampler only
    if F_SAMPLERS & B_SOBOL and (F_SAMPLERS == B_SOBOL or sampler == SOBOL):
        return sobol_sample_2d(seed, pixel, index, dim)
    if F_SAMPLERS & B_CMJ and (F_SAMPLERS == B_CMJ or sampler == CMJ):
        p, i = _pattern(seed, pixel, index, spp, dim)
        return cmj(i, spp, p)
    if F_SAMPLERS & B_STRATIFIED and (F_SAMPLERS == B_STRATIFIED or sampler == STRATIFIED):
        return stratified_sample_2d(seed, pixel, index, spp, dim)
    return independent_sample_2d(seed, pixel, index, dim)


@njit(**JIT)
def sample_pixel_lens(sampler, seed, pixel, index, spp):
    """Pairs DIM_PIXEL and DIM_LENS of one sample together, (a, b, lens_u, lens_v): the values of
    two `sample_2d` calls; the Sobol' sampler computes its 4D point once (~35 % less time)."""
    if F_SAMPLERS & B_SOBOL and (F_SAMPLERS == B_SOBOL or sampler == SOBOL):
        return sobol_sample_4d(np.int64(seed) & _M32, np.int64(pixel), np.int64(index))
    a, b = sample_2d(sampler, seed, pixel, index, spp, pixel_dim())
    lu, lv = sample_2d(sampler, seed, pixel, index, spp, lens_dim())
    return a, b, lu, lv


@njit(**JIT)
def sample_1d(sampler, seed, pixel, index, spp, dim):
    """A 1D sample in [0, 1) for pair ``dim``, stratified into ``spp`` strata by every sampler
    except INDEPENDENT.  It is the first coordinate of ``sample_2d`` for INDEPENDENT and SOBOL, the
    second for CMJ (its y is stratified into N strata even when N is not square); for STRATIFIED
    it is a 1D jittered sample (spp strata instead of the grid's nx), so a pair should be used
    either as 1D or as 2D, not both."""
    if F_SAMPLERS & B_STRATIFIED and (F_SAMPLERS == B_STRATIFIED or sampler == STRATIFIED):
        seed = np.int64(seed) & _M32
        spp = max(np.int64(spp), 1)
        p, i = _pattern(seed, np.int64(pixel), np.int64(index), spp, np.int64(dim))
        s = permute(i, spp, p)
        return min((s + randfloat(s, p * 0x8DA6B343)) / spp, _ONE_MINUS)
    if F_SAMPLERS & B_SOBOL and (F_SAMPLERS == B_SOBOL or sampler == SOBOL):
        # Only the first coordinate: skip the second dimension's work.
        seed = np.int64(seed) & _M32
        pixel = np.int64(pixel)
        index = np.int64(index)
        if dim <= DIM_LENS:
            pseed = hash3(seed, pixel, 0x5EED0001)
            d0 = 2 * dim
        else:
            pseed = hash3(seed, pixel, dim)
            d0 = 0
        shuffled = nested_uniform_scramble(index, pseed)
        return to_unit(_sobol_owen(shuffled, pseed, d0))
    if F_SAMPLERS & B_CMJ and (F_SAMPLERS == B_CMJ or sampler == CMJ):
        return sample_2d(sampler, seed, pixel, index, spp, dim)[1]
    return sample_2d(sampler, seed, pixel, index, spp, dim)[0]


# The same functions inlined by LLVM into their callers.  The path integrator draws five numbers per path
# vertex, and inlined there they cost less (glossy benchmark scene, CPU per sample 988 -> 895 ns); the
# cook integrator draws few and is faster calling them (gallery.xml 521 -> 567 ns inlined).  Both are
# compiled from the same code, so they share their cache entries.
sample_1d_inlined = njit(**INLINE_JIT)(sample_1d.py_func)
sample_2d_inlined = njit(**INLINE_JIT)(sample_2d.py_func)


def sampler_id(name_or_id) -> int:
    """Map a sampler name ('sobol', ...) or id to the integer id; ValueError if unknown."""
    if isinstance(name_or_id, str):
        try:
            return SAMPLER_NAMES[name_or_id.lower()]
        except KeyError:
            raise ValueError('unknown sampler %r (choose from %s)'
                             % (name_or_id, ', '.join(SAMPLER_NAMES))) from None
    i = int(name_or_id)
    if i not in SAMPLER_NAMES.values():
        raise ValueError('unknown sampler id %d' % i)
    return i
