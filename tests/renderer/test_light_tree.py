"""The light tree (host/light_tree.py, kernel/light_tree.py): `choose_lights` takes each light as many
times per vertex on average as `light_pmf` reports (at least one sample; a dominant light at every
vertex), the importance of
a point light is its power over the squared distance times the receiver's cosine, cone unions hold
both cones, a light behind a one-sided rect's back or below the receiver's horizon is never chosen, and
a scene's one light is sampled at every vertex without a choice exactly where the tree would choose it."""
import math

import numpy as np
import pytest

from rtc.renderer import description as D
from rtc.renderer.host.build import build
from rtc.renderer.host.light_selection import path_lights
from rtc.renderer.host.light_tree import ENTIRE, cone_union
from rtc.renderer.kernel.light_sampling import sample_ld
from rtc.renderer.kernel.light_tree import (NO_SAMPLE, SPLIT_BELOW, SPLIT_DEEP, _enter, choose_lights, importances,
                                           light_pmf, lone_light)
from rtc.renderer.kernel.tables import T_C, T_COS_O, T_PHI, T_RADIUS, T_SIN_O, T_W, TREE_COLS, TREE_LEVELS, TREE_SLOTS
from tests.renderer.handmade import look_at, quad, scene, translate


def _rect(center, facing, size, radiance):
    """A rect light at `center` emitting towards `facing` (its local -Z)."""
    z = -np.asarray(facing, float) / np.linalg.norm(facing)
    x = np.cross([0.0, 1.0, 0.3], z)
    x /= np.linalg.norm(x)
    m = np.eye(4)
    m[:3, 0], m[:3, 1], m[:3, 2], m[:3, 3] = x, np.cross(z, x), z, center
    return D.Light(path='/r', type=D.RECT, matrix=m, radiance=(radiance,) * 3, width=size, height=size)


def _lights_scene():
    rng = np.random.default_rng(3)
    lights = [D.Light(path=f'/p{k}', type=D.POINT, matrix=translate(*rng.uniform([-5, 0.5, -5], [5, 3, 5])),
                      radiance=(float(rng.uniform(0.5, 5)),) * 3) for k in range(40)]
    lights += [_rect(rng.uniform([-5, 1, -5], [5, 4, 5]), (0, -1, 0), 0.5, 3.0) for _ in range(20)]
    lights += [D.Light(path='/s', type=D.SPHERE, matrix=translate(0, 2, 0), radiance=(4.0,) * 3, radius=0.3),
               D.Light(path='/sky', type=D.DOME, matrix=np.eye(4), radiance=(0.2,) * 3)]
    cam = D.Camera(path='/cam', matrix=look_at((0.0, 3.0, 8.0), (0.0, 0.0, 0.0)))
    return scene([D.Container('/', meshes=[quad(12.0)])], [D.Material('/m')], lights, cam)


@pytest.fixture(scope='module')
def lights():
    desc = _lights_scene()
    built = build(desc)
    L, _ = path_lights(desc, built.data.li_f, built.top.bounds(), len(built.top.groups))
    yield L
    built.close()


POINTS = [((0.0, 0.0, 0.0), (0.0, 1.0, 0.0)), ((3.0, 0.0, -2.0), (0.0, 1.0, 0.0)), ((-4.0, 2.0, 1.0), (1.0, 0.0, 0.0))]


@pytest.mark.parametrize('p, n', POINTS)
def test_expected_sample_counts_match_the_draws(lights, p, n):
    """light_pmf(k) is the expected number of samples of light k per vertex: one main sample and at
    most two side samples of other lights, each returned with that number, and stratified draws of u
    take each light that many times per draw, to within the count granularity."""
    pmf = np.array([light_pmf(lights, p, n, k) for k in range(62)])
    assert 1.0 - 1e-9 <= pmf.sum() < 3.0
    draws = 20000
    counts = np.zeros(62)
    sides = 0
    for i in range(draws):
        (main, pm), *rest = chosen = choose_lights(lights, p, n, (i + 0.5) / draws)
        assert main >= 0 and main not in [k for k, _ in rest]
        sides += sum(k >= 0 for k, _ in rest)
        for k, pk in chosen:
            if k >= 0:
                counts[k] += 1
                assert pk == pytest.approx(pmf[k], rel=1e-9)
    assert np.max(np.abs(counts / draws - pmf)) < 5.0 / draws + 1e-9
    assert sides / draws == pytest.approx(pmf.sum() - 1.0, abs=5.0 / draws)


def test_a_dominant_light_is_sampled_at_every_vertex():
    """One bright rect among faint point lights: the walk splits on its whole trail and takes it every
    time (expected count 1: the variance of choosing it is gone, and its samples keep the sampler's
    stratification), the faint lights in side samples."""
    rng = np.random.default_rng(5)
    faint = [D.Light(path=f'/p{k}', type=D.POINT, matrix=translate(*rng.uniform([-8, 0.5, -8], [8, 3, 8])),
                     radiance=(0.01,) * 3) for k in range(200)]
    desc = scene([D.Container('/', meshes=[quad(12.0)])], [D.Material('/m')],
                 [_rect((0.0, 6.0, 0.0), (0, -1, 0), 3.0, 20.0)] + faint,
                 D.Camera(path='/cam', matrix=look_at((0.0, 3.0, 8.0), (0.0, 0.0, 0.0))))
    built = build(desc)
    L, _ = path_lights(desc, built.data.li_f, built.top.bounds(), len(built.top.groups))
    try:
        for x, z in ((0.0, 0.0), (-5.0, 3.0), (4.0, 4.0)):
            p = (x, -3.0, z - 8.0)                    # floor points, relative to the camera
            pmf = np.array([light_pmf(L, p, (0.0, 1.0, 0.0), k) for k in range(201)])
            assert pmf[0] == 1.0
            assert 0.0 < pmf[1:].sum() < 0.1
            draws = 4000
            mains = {choose_lights(L, p, (0.0, 1.0, 0.0), (i + 0.5) / draws)[0] for i in range(draws)}
            assert mains == {(0, 1.0)}                # the dominant light, at every draw
    finally:
        built.close()


def _trail_qs(L, k, p, n):
    """The probability q of the less likely child at each node on light k's trail (walking the blocks as
    the kernel does: slot -1 is a block's root, the children of slot s are slots 2s + 2 and 2s + 3)."""
    tf, ti = L.tree_f, L.tree_i
    w = np.zeros(TREE_SLOTS, np.float32)
    block, slot, qs = 0, -1, []
    importances(tf, block, p, n, w)
    for level in range(L.depth[k]):
        c0 = 2 * slot + 2
        i0, i1 = float(w[c0]), float(w[c0 + 1])       # (the kernels' pair probabilities are in double)
        qs.append(min(i0, i1) / (i0 + i1))
        s = c0 + ((L.trail[k] >> level) & 1)
        if ti[block, s] > 0:
            block, slot = ti[block, s], -1
            importances(tf, block, p, n, w)
        else:
            slot = s
    return qs


def test_a_third_split_counts_the_chance_that_two_side_samples_came_before():
    """Eight point lights on a line, far from the receiver (so importance ~ power), with powers that
    make light 0's trail split three times: q = 0.24, 0.24 at the top, 0.008 (below SPLIT_DEEP) at the
    bottom.  Light 1, past the third split's less likely child, has the expected count q3 times the
    chance that fewer than two side samples were taken above, 1 - q1 q2 (from the importances, an
    independent closed form), and stratified draws take it that often."""
    top, rest = 0.76, 0.24                            # root: lights 0-3 / 4-7
    pair01, pair23 = 0.76 * top, 0.24 * top           # lights 0-1 / 2-3
    powers = [(1 - 0.008) * pair01, 0.008 * pair01, pair23 / 2, pair23 / 2] + [rest / 4] * 4
    lights = [D.Light(path=f'/p{k}', type=D.POINT, matrix=translate(float(k), 0.0, 0.0), radiance=(100.0 * w,) * 3)
              for k, w in enumerate(powers)]
    desc = scene([D.Container('/', meshes=[quad(4.0, y=-50.0)])], [D.Material('/m')], lights,
                 D.Camera(path='/cam', matrix=look_at((3.5, 0.0, 1000.0), (3.5, 0.0, 0.0))))
    built = build(desc)
    L, _ = path_lights(desc, built.data.li_f, built.top.bounds(), len(built.top.groups))
    try:
        p = tuple(np.array([3.5, 0.0, 1000.0]) - built.origin)     # at the camera (float coordinates)
        n = (0.0, 0.0, -1.0)                          # facing the lights
        qs = _trail_qs(L, 0, p, n)                    # light 0's trail: the q of each node on it
        assert qs == pytest.approx([0.24, 0.24, 0.008], rel=1e-3) and qs[2] <= SPLIT_DEEP < qs[1] <= SPLIT_BELOW
        assert light_pmf(L, p, n, 0) == 1.0
        assert light_pmf(L, p, n, 1) == pytest.approx(qs[2] * (1.0 - qs[0] * qs[1]), rel=1e-9)
        pmf = [light_pmf(L, p, n, k) for k in range(8)]
        draws = 100000
        taken = 0
        for i in range(draws):
            for k, pk in choose_lights(L, p, n, (i + 0.5) / draws):
                if k >= 0:
                    assert pk == pytest.approx(pmf[k], rel=1e-9)
                    taken += k == 1
        assert taken / draws == pytest.approx(pmf[1], abs=3.0 / draws)
    finally:
        built.close()


def test_the_dome_is_chosen_with_its_share(lights):
    assert light_pmf(lights, (0.0, 0.0, 0.0), (0.0, 1.0, 0.0), 61) == pytest.approx(0.5)


def test_a_rect_never_lights_what_is_behind_it_or_below_the_horizon():
    desc = scene([D.Container('/', meshes=[quad(4.0)])], [D.Material('/m')],
                 [_rect((0.0, 2.0, 0.0), (0.0, -1.0, 0.0), 1.0, 5.0), _rect((0.0, 2.0, 3.0), (0.0, -1.0, 0.0), 1.0, 5.0)],
                 D.Camera(path='/cam', matrix=look_at((0.0, 3.0, 8.0), (0.0, 0.0, 0.0))))
    built = build(desc)
    L, _ = path_lights(desc, built.data.li_f, built.top.bounds(), len(built.top.groups))
    try:                                              # points relative to the camera, as the kernels see them
        above = (0.0, 5.0 - 3.0, -8.0)                # above both rects: their backs face it
        assert light_pmf(L, above, (0.0, 1.0, 0.0), 0) == 0.0 and light_pmf(L, above, (0.0, 1.0, 0.0), 1) == 0.0
        assert all(k < 0 for k, _ in choose_lights(L, above, (0.0, 1.0, 0.0), 0.3))
        below = (0.0, -3.0, -8.0)                     # under the first rect, 3 from the second
        assert light_pmf(L, below, (0.0, 1.0, 0.0), 0) > light_pmf(L, below, (0.0, 1.0, 0.0), 1) > 0.0
    finally:
        built.close()


def test_a_point_lights_importance_is_power_over_distance_squared_times_the_cosine():
    """A block whose slot 3 is a point light (centre (1, 2, 0), radius 0, phi 10, every direction) and
    whose other slots are empty: the slot's importance is phi / d^2 times the receiver's cosine (to
    float32's precision, the table's), the others' 0."""
    tf = np.zeros((1, TREE_COLS * TREE_SLOTS), np.float32)
    slots = tf[0].reshape(TREE_COLS, TREE_SLOTS)      # field-major: row = field, column = slot
    slots[T_C:T_C + 3, 3] = (1.0, 2.0, 0.0)
    slots[T_PHI, 3] = 10.0
    slots[T_W:T_W + 3, 3] = ENTIRE[0]
    slots[T_COS_O, 3] = -1.0
    p, n = (0.0, 0.0, 0.0), (0.0, 1.0, 0.0)
    w = np.full(TREE_SLOTS, np.nan, np.float32)
    importances(tf, 0, p, n, w)
    assert w[3] == pytest.approx(10.0 / 5.0 * 2.0 / math.sqrt(5.0), rel=1e-6)
    assert np.all(np.delete(w, 3) == 0.0)


def test_a_flat_emitter_lights_its_back_only_when_two_sided():
    """A unit square facing +y at the origin (normal cone of half-angle 0: sin theta_o = 0, so its
    two-sidedness is the sign bit of -0.0): a point 4 below it, facing up, gets importance 0 from the
    one-sided node and, from the two-sided one, what a point 4 above facing down gets from either."""
    tf = np.zeros((1, TREE_COLS * TREE_SLOTS), np.float32)
    slots = tf[0].reshape(TREE_COLS, TREE_SLOTS)
    for j, two in ((0, False), (1, True)):
        slots[T_RADIUS, j] = math.sqrt(0.5)
        slots[T_PHI, j] = 1.0
        slots[T_W:T_W + 3, j] = (0.0, 1.0, 0.0)
        slots[T_COS_O, j] = 1.0
        slots[T_SIN_O, j] = -0.0 if two else 0.0
    below, above = np.zeros(TREE_SLOTS, np.float32), np.zeros(TREE_SLOTS, np.float32)
    importances(tf, 0, (0.0, -4.0, 0.0), (0.0, 1.0, 0.0), below)
    importances(tf, 0, (0.0, 4.0, 0.0), (0.0, -1.0, 0.0), above)
    assert above[0] > 0.0 and above[0] == above[1]
    assert below[0] == 0.0 and below[1] == above[0]


def test_entering_a_block_gives_each_sibling_pair_the_first_childs_probability():
    """`_enter` (the walk's step into a block): each pair k of siblings (slots 2k, 2k + 1) gets
    w[2k] / (w[2k] + w[2k + 1]) from the block's importances, computed here in float64 from
    `importances`' own output (so a pair, a slot or a denominator mixed up fails), and NaN where
    both are 0 (the walk takes no child there)."""
    rng = np.random.default_rng(3)
    tf = np.zeros((1, TREE_COLS * TREE_SLOTS), np.float32)
    slots = tf[0].reshape(TREE_COLS, TREE_SLOTS)
    for j in range(10):                               # slots 0-9 point lights, 10-15 empty (phi 0)
        slots[T_C:T_C + 3, j] = rng.uniform(-5.0, 5.0, 3)
        slots[T_PHI, j] = rng.uniform(0.5, 3.0)
        slots[T_W:T_W + 3, j] = ENTIRE[0]
        slots[T_COS_O, j] = -1.0
    p, n = (0.0, -6.0, 0.0), (0.0, 1.0, 0.0)
    w, pr = np.full(TREE_SLOTS, np.nan, np.float32), np.full(TREE_SLOTS, -1.0)
    _enter(tf, 0, p, n, w, pr)
    ref = np.full(TREE_SLOTS, np.nan, np.float32)
    importances(tf, 0, p, n, ref)
    assert np.array_equal(w, ref) and np.all(ref[:10] > 0.0)
    for k in range(5):
        a, b = float(ref[2 * k]), float(ref[2 * k + 1])
        assert pr[k] == a / (a + b)
    assert np.all(np.isnan(pr[5:8]))


def test_the_tree_is_stored_in_blocks_of_three_levels():
    """1000 point lights: a balanced binary tree (depth 9 or 10), every light reached by following its
    trail through the blocks, each node's phi the sum of its children's, a root block of one level
    ((10 - 1) % 3 + 1: so that the blocks below it are full) and 1 + 2 + 16 + 128 blocks in all."""
    rng = np.random.default_rng(9)
    lights = [D.Light(path=f'/p{k}', type=D.POINT, matrix=translate(*rng.uniform(-10, 10, 3)),
                      radiance=(float(rng.uniform(0.1, 2.0)),) * 3) for k in range(1000)]
    desc = scene([D.Container('/', meshes=[quad(4.0)])], [D.Material('/m')], lights,
                 D.Camera(path='/cam', matrix=look_at((0.0, 3.0, 30.0), (0.0, 0.0, 0.0))))
    built = build(desc)
    L, _ = path_lights(desc, built.data.li_f, built.top.bounds(), len(built.top.groups))
    try:
        assert TREE_LEVELS == 3 and set(L.depth.tolist()) == {9, 10} and len(L.tree_i) == 147
        phi = L.tree_f.reshape(len(L.tree_f), TREE_COLS, TREE_SLOTS)[:, T_PHI].astype(np.float64)
        assert np.count_nonzero(phi[0]) == 2 and np.all(L.tree_i[0, :2] > 0)
        for k in range(1000):
            block, slot = 0, -1
            for level in range(L.depth[k]):
                s = 2 * slot + 2 + ((L.trail[k] >> level) & 1)
                code = L.tree_i[block, s]
                if level + 1 == L.depth[k]:
                    assert code == -1 - k
                elif code > 0:                        # a block's last level: its children in that block
                    assert phi[block, s] == pytest.approx(phi[code, 0] + phi[code, 1], rel=1e-5)
                    block, slot = code, -1
                else:
                    assert code == 0 and phi[block, s] == pytest.approx(phi[block, 2 * s + 2] + phi[block, 2 * s + 3], rel=1e-5)
                    slot = s
    finally:
        built.close()


def test_cone_union_holds_both_cones():
    rng = np.random.default_rng(7)
    for _ in range(200):
        a = rng.normal(size=3)
        b = rng.normal(size=3)
        ca, cb = rng.uniform(-0.2, 1.0, 2)
        w, c = cone_union((a / np.linalg.norm(a), ca), (b / np.linalg.norm(b), cb))
        for axis, cos_half in ((a / np.linalg.norm(a), ca), (b / np.linalg.norm(b), cb)):
            # the cone's axis and every direction on its rim lie in the union
            t = np.cross(axis, [0.3, 0.5, 0.8])
            t /= np.linalg.norm(t)
            s = math.sqrt(max(0.0, 1 - cos_half * cos_half))
            for phi in np.linspace(0, 2 * math.pi, 16):
                rim = cos_half * axis + s * (math.cos(phi) * t + math.sin(phi) * np.cross(axis, t))
                assert np.dot(rim, w) >= c - 1e-9


@pytest.mark.parametrize('light', [
    _rect((0.0, 2.0, 0.0), (0.3, -1.0, 0.2), 1.0, 5.0),
    D.Light(path='/s', type=D.SPHERE, matrix=translate(0.5, 1.5, 0.0), radiance=(4.0,) * 3, radius=0.3),
    D.Light(path='/sky', type=D.DOME, matrix=np.eye(4), radiance=(0.2,) * 3)])
def test_a_lone_light_is_the_trees_choice_wherever_it_can_light_the_vertex(light):
    """`lone_light` (the path kernel's shortcut for one-light scenes: no choice, no 1D sample) names the
    light; wherever the tree chooses it, it chooses it alone with count 1, as light_pmf reports; where
    the tree does not (the back of a rect), the light's own samples carry no light (pdf 0), so skipping
    the tree changes no estimate."""
    desc = scene([D.Container('/', meshes=[quad(4.0)])], [D.Material('/m')], [light],
                 D.Camera(path='/cam', matrix=look_at((0.0, 3.0, 8.0), (0.0, 0.0, 0.0))))
    built = build(desc)
    L, _ = path_lights(desc, built.data.li_f, built.top.bounds(), len(built.top.groups))
    try:
        assert lone_light(L) == 0
        rng = np.random.default_rng(11)
        chosen = culled = 0
        for _ in range(400):
            p = tuple(rng.uniform(-4.0, 4.0, 3) - (0.0, 3.0, 8.0))          # camera-relative, as the kernels see it
            n = rng.normal(size=3)
            n = tuple(n / np.linalg.norm(n))
            assert light_pmf(L, p, n, 0) == 1.0
            for u in (0.1, 0.6):
                main, side1, side2 = choose_lights(L, p, n, u)
                assert side1 == NO_SAMPLE and side2 == NO_SAMPLE
                if main[0] >= 0:
                    chosen += 1
                    assert main == (0, 1.0)
                else:
                    culled += 1
                    assert all(not sample_ld(built.data, L, 0, p, n, a, b)[3] > 0.0
                               for a in (0.05, 0.5, 0.95) for b in (0.05, 0.5, 0.95))
        assert chosen > 400 and (culled > 40 if light.type == D.RECT else culled == 0)
    finally:
        built.close()


def test_two_lights_are_not_lone(lights):
    assert lone_light(lights) == -1


def _median_tree(items, centres):
    """An independent reference of the tree `median_order` builds: recursively, a node's lights sorted stably by
    their centres along the longest axis of the centres' box, its first n // 2 the first child's."""
    if len(items) == 1:
        return items[0]
    c = centres[items]
    axis = int(np.argmax(c.max(0) - c.min(0)))
    items = [items[j] for j in np.argsort(c[:, axis], kind='stable')]
    h = len(items) // 2
    return _median_tree(items[:h], centres), _median_tree(items[h:], centres)


def _flat(t):
    return [t] if isinstance(t, int) else _flat(t[0]) + _flat(t[1])


@pytest.mark.parametrize('n', [1, 2, 3, 7, 100, 1001])
def test_median_order_is_the_median_split_tree(n):
    """`median_order`, sorting every node of a level at once, gives the leaves of the recursive median split in
    its order, its inner nodes as the runs (start, size) of that order, level by level (centres on a coarse grid:
    ties, which keep their parent's order)."""
    from rtc.renderer.host.light_tree import median_order
    centres = np.round(np.random.default_rng(n).uniform(-3, 3, (n, 3)))
    order, levels = median_order(centres)
    ref = _median_tree(list(range(n)), centres)
    assert order.tolist() == _flat(ref)
    runs, frontier = [], [(0, ref)]
    while frontier:                                   # the reference's inner nodes, level by level
        inner = [(s, t) for s, t in frontier if not isinstance(t, int)]
        if inner:
            runs.append(sorted((s, len(_flat(t))) for s, t in inner))
        frontier = [(s + k * len(_flat(t[0])), t[k]) for s, t in inner for k in (0, 1)]
    assert [sorted(zip(a.tolist(), b.tolist())) for a, b in levels] == runs


def test_every_node_bounds_the_lights_below_it():
    """Each inner node of a tree of 1,200 lights - rects facing every way, some two-sided, and points -: its box
    holds its lights' boxes, its phi is their sum, its cone holds each of their cones (the angle from its axis to
    theirs plus their half-angle at most its half-angle), it is two-sided where one of them is; the compiled fold
    of the cones (`_fold_cones`, for trees above FOLD_COMPILED unions) equals the Python one bit for bit."""
    from rtc.renderer.host import light_tree as T
    rng = np.random.default_rng(11)
    n = 1200
    lo = rng.uniform(-10, 10, (n, 3))
    w = rng.normal(size=(n, 3)) * 0.6 + (0.0, -1.0, 0.0)
    w /= np.linalg.norm(w, axis=1)[:, None]
    bounds = [(lo[k], lo[k] + 0.3, float(rng.uniform(0.1, 2.0)), (w[k], 1.0), k % 5 == 0) for k in range(n)]
    for k in range(0, n, 7):                          # points among them: their ancestors emit everywhere
        bounds[k] = (lo[k], lo[k], bounds[k][2], ENTIRE, False)
    order, levels = T.median_order(0.5 * (lo + np.array([b[1] for b in bounds])))
    rec, rows = T._node_bounds(bounds, order, levels)
    assert len(rec) == 2 * n - 1 and sum(int(s.sum()) for _, s in levels) < T.FOLD_COMPILED   # (folded in Python)
    for start, size in levels:
        for s, m in zip(start.tolist(), size.tolist()):
            r, ks = rec[rows[s, m]], order[s:s + m]
            box_lo, box_hi = np.min([bounds[k][0] for k in ks], 0), np.max([bounds[k][1] for k in ks], 0)
            np.testing.assert_allclose(r[T_C:T_C + 3], 0.5 * (box_lo + box_hi), rtol=1e-12, atol=1e-12)
            assert r[T_RADIUS] == pytest.approx(0.5 * np.linalg.norm(box_hi - box_lo), rel=1e-12)
            assert r[T_PHI] == pytest.approx(sum(bounds[k][2] for k in ks), rel=1e-12)
            assert (math.copysign(1.0, r[T_SIN_O]) < 0) == any(bounds[k][4] for k in ks)
            if r[T_COS_O] > -1.0:
                for k in ks:
                    wk, ck = bounds[k][3]
                    apart = math.acos(min(1.0, float(np.dot(r[T_W:T_W + 3], wk))))
                    assert apart + math.acos(ck) <= math.acos(r[T_COS_O]) + 1e-9
        axes, cos_o = np.array([b[3][0] for b in bounds]), np.array([b[3][1] for b in bounds])
        compiled, python = np.empty((len(start), 4)), np.empty((len(start), 4))
        T._fold_cones(axes, cos_o, order, start, size, compiled)
        T._fold_cones_python(axes, cos_o, order, start, size, python)
        assert np.array_equal(compiled, python)
    assert np.count_nonzero(rec[n:, T_COS_O] > -1.0) > 100       # (cones to check: not every node's is ENTIRE)
