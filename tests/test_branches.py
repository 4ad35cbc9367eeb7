"""Assembly branches on multi-loop linkages: every requested branch is reached or refused.

The linkages (a Jansen leg from its published link lengths, the Stephenson six-bar of
mechanisms/six-bar.yaml) are generated with their loops closed by revolute joints (binary links
as bodies) or by distance joints (binary links as massless distances). For every combination of
`assembly: {branch: ...}` signs the assembled pose is checked geometrically, independently of
planarkin's determinant signs: each loop's knee lies on one side of the line through the two
points the loop hangs from (the sign of a cross product of two link vectors). Requesting a loop's
other sign must put its knee on the other side, leave the other loops' sides as requested, and
keep every link length; all combinations must give distinct geometric configurations.
"""

from __future__ import annotations

import itertools
import math
import re
import sys
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).resolve().parent))

import planarkin  # noqa: E402
from clitools import run_cli  # noqa: E402

# Jansen's "holy numbers" (Theo Jansen, The Great Pretender; Wikipedia "Jansen's linkage")
JANSEN = dict(a=38.0, b=41.5, c=39.3, d=40.1, e=55.8, f=39.4, g=36.7, h=65.7, i=49.0, j=50.0,
              k=61.9, l=7.8, m=15.0)


def num(x: float) -> str:
    return repr(float(x))


def cross(u, v) -> float:
    return float(u[0] * v[1] - u[1] * v[0])


def circles(P1, r1, P2, r2, side):
    """The intersection X of the circles (P1, r1) and (P2, r2) with sign(cross(P2 - P1, X - P1))
    = side."""
    P1, P2 = np.asarray(P1, float), np.asarray(P2, float)
    dv = P2 - P1
    dd = math.hypot(*dv)
    x = (r1 * r1 - r2 * r2 + dd * dd) / (2 * dd)
    y = math.sqrt(r1 * r1 - x * x)
    ex = dv / dd
    ey = np.array([-ex[1], ex[0]])
    return P1 + x * ex + side * y * ey


def local(frame, ang, P):
    """P in the frame at `frame` rotated by ang."""
    d = np.asarray(P) - np.asarray(frame)
    c, s = math.cos(ang), math.sin(ang)
    return (c * d[0] + s * d[1], -s * d[0] + c * d[1])


def angle(P, Q):
    return math.atan2(Q[1] - P[1], Q[0] - P[0])


# == the Jansen leg ==============================================================================

def jansen_points(th):
    """Joint positions of the usual (walking) assembly at crank angle th: crank axle O, crank
    pin A, ground pivot B, upper knee C, lower knee D, E on the triangle BCE, F on DFG, foot G."""
    J = JANSEN
    O = np.zeros(2)
    B = np.array([-J["a"], -J["l"]])
    A = J["m"] * np.array([math.cos(th), math.sin(th)])
    C = circles(A, J["j"], B, J["b"], -1)       # above the line A -> B (which points left)
    D = circles(A, J["k"], B, J["c"], +1)       # below it
    E = circles(B, J["d"], C, J["e"], +1)       # the triangle's outer corner, |BE| = d
    F = circles(E, J["f"], D, J["g"], -1)
    G = circles(D, J["i"], F, J["h"], +1)       # the foot, below
    return dict(O=O, A=A, B=B, C=C, D=D, E=E, F=F, G=G)


def jansen_yaml(closure: str, hints: dict | None = None, th=0.4, jitter=0.02) -> str:
    """Jansen leg driven by the crank angle th + 2 pi t (rad, lengths in mm). closure 'revolute':
    the binary links j, k, f are bodies; 'distance': they are distance joints. Estimates are the
    exact pose of jansen_points with every coordinate moved by about jitter (relative)."""
    P = jansen_points(th)
    J = JANSEN
    bodies, joints = {}, []
    rng = np.random.default_rng(7)

    def body(name, at, towards):
        ph = angle(P[at], P[towards])
        bodies[name] = (P[at], ph)

    def s(name, pt):
        fr, ph = bodies[name]
        return "[" + ", ".join(num(v) for v in local(fr, ph, P[pt])) + "]"

    body("crank", "O", "A")
    body("tri_bce", "B", "C")
    body("linkc", "B", "D")
    body("tri_dfg", "D", "F")
    if closure == "revolute":
        body("linkj", "A", "C")
        body("linkk", "A", "D")
        body("linkf", "E", "F")
    rev = lambda i, j, pt: joints.append(
        f"  - {{type: revolute, i: {i}, j: {j}, si: {s(i, pt) if i != 'ground' else gp(pt)}, "
        f"sj: {s(j, pt)}}}")
    dist = lambda i, j, pi_, pj, c: joints.append(
        f"  - {{type: distance, i: {i}, j: {j}, si: {s(i, pi_)}, sj: {s(j, pj)}, c: {num(c)}}}")
    gp = lambda pt: "[" + ", ".join(num(v) for v in P[pt]) + "]"
    rev("ground", "crank", "O")
    rev("ground", "tri_bce", "B")
    rev("ground", "linkc", "B")
    rev("linkc", "tri_dfg", "D")
    if closure == "revolute":
        rev("crank", "linkj", "A")
        rev("linkj", "tri_bce", "C")
        rev("crank", "linkk", "A")
        rev("linkk", "linkc", "D")
        rev("tri_bce", "linkf", "E")
        rev("linkf", "tri_dfg", "F")
    else:
        dist("crank", "tri_bce", "A", "C", J["j"])
        dist("crank", "linkc", "A", "D", J["k"])
        dist("tri_bce", "tri_dfg", "E", "F", J["f"])
    lines = []
    for name, (fr, ph) in bodies.items():
        e = rng.normal(size=3) * jitter
        lines.append(f"  {name}: {{q: [{num(fr[0] + 10 * e[0])}, {num(fr[1] + 10 * e[1])}, "
                     f"{num(ph + e[2])}]}}")
    pts = {"A": "crank", "C": "tri_bce", "E": "tri_bce", "D": "linkc", "F": "tri_dfg",
           "G": "tri_dfg"}
    points = [f"  {p}: {{body: {b}, s: {s(b, p)}}}" for p, b in pts.items()]
    hint = ""
    if hints:
        hint = "assembly: {branch: {" + ", ".join(f"{k}: '{v}'" for k, v in hints.items()) + "}}\n"
    return (f"# Jansen leg, loops closed by {closure} joints (generated by "
            f"tests/test_branches.py)\nname: jansen\nunits: {{length: mm, angle: rad}}\n"
            f"bodies:\n" + "\n".join(lines) + "\njoints:\n" + "\n".join(joints) +
            f"\ndrivers:\n  - {{type: angle, body: crank, f: \"{num(th)} + 2*pi*t\"}}\n"
            f"points:\n" + "\n".join(points) + "\nanalysis: {start: 0, end: 1, steps: 36}\n"
            + hint)


# the body that names each loop in assembly: branch:, and the loop's knee side:
# (knee, from, to) -> sign(cross(to - from, knee - from))
JANSEN_LOOPS = {"tri_bce": ("C", "A", "B"), "linkc": ("D", "A", "B"), "tri_dfg": ("F", "E", "D")}


def _sides(res, loops, ground=None):
    """Geometric side of every loop's knee at t = start, from the result's point columns."""
    ground = ground or {}

    def pos(name):
        if name in ground:
            return np.asarray(ground[name])
        p = res.point(name)
        return np.array([p["x"][0], p["y"][0]])
    return {key: int(np.sign(cross(pos(to) - pos(fr), pos(knee) - pos(fr))))
            for key, (knee, fr, to) in loops.items()}


def _lengths(res, pairs, ground=None):
    ground = ground or {}

    def pos(name):
        if name in ground:
            return np.asarray(ground[name])
        p = res.point(name)
        return np.array([p["x"][0], p["y"][0]])
    return {(u, v): float(np.hypot(*(pos(u) - pos(v)))) for u, v, _ in pairs}


def _modes(res):
    return {md["bodies"][0]: md["branch"] for md in res.info.assembly["modes"]}


def _loop_sign(res, body):
    """planarkin's sign of the loop holding body (the mode whose bodies include it)."""
    for md in res.info.assembly["modes"]:
        if body in md["bodies"]:
            return md["branch"]
    raise AssertionError(f"{body} in no loop: {res.info.assembly['modes']}")


def _check_every_combination(make, loops, lengths, ground=None, feasible=None):
    """For every combination of requested signs: either the run assembles (status 0 over a short
    run), every loop's geometric side flips exactly when its requested sign differs from the
    plain assembly's, link lengths hold and planarkin reports the requested signs; or, exactly
    when feasible(sides) (the geometry, computed here) says a downstream loop cannot close on
    those sides, the model is refused with a message naming that loop."""
    plain = planarkin.solve(planarkin.load("plain.yaml", text=make(None)), end=0.01, steps=1)
    assert plain.status == 0, plain.message
    side0 = _sides(plain, loops, ground)
    sign0 = {k: _loop_sign(plain, k) for k in loops}
    seen = set()
    refused = 0
    for combo in itertools.product("+-", repeat=len(loops)):
        hints = dict(zip(loops, combo))
        expect = {k: side0[k] if hints[k] == sign0[k] else -side0[k] for k in loops}
        model = planarkin.load("hinted.yaml", text=make(hints))
        ok, loop = feasible(expect) if feasible else (True, None)
        if not ok:
            with pytest.raises(planarkin.InputError) as exc:
                planarkin.solve(model, end=0.01, steps=1)
            msg = str(exc.value)
            assert "cannot be closed" in msg and loop in msg, (hints, msg)
            refused += 1
            continue
        res = planarkin.solve(model, end=0.01, steps=1)
        assert res.status == 0, (hints, res.message)
        side = _sides(res, loops, ground)
        assert side == expect, (hints, side, side0)
        for k in loops:
            assert _loop_sign(res, k) == hints[k]
        want = {(a, b): c for a, b, c in lengths}
        for (u, v), L in _lengths(res, lengths, ground).items():
            assert abs(L - want[(u, v)]) <= 1e-9 * want[(u, v)], (hints, u, v, L)
        seen.add(tuple(side[k] for k in loops))
    assert len(seen) + refused == 2 ** len(loops)
    return refused


JANSEN_LENGTHS = [("A", "C", JANSEN["j"]), ("A", "D", JANSEN["k"]), ("E", "F", JANSEN["f"]),
                  ("D", "G", JANSEN["i"]), ("F", "G", JANSEN["h"]), ("C", "E", JANSEN["e"]),
                  ("B", "C", JANSEN["b"]), ("B", "D", JANSEN["c"]), ("D", "F", JANSEN["g"]),
                  ("B", "E", JANSEN["d"])]
JANSEN_GROUND = {"B": (-JANSEN["a"], -JANSEN["l"])}


@pytest.mark.parametrize("closure", ("revolute", "distance"))
def test_jansen_every_branch_combination(closure):
    """All 8 combinations close at crank angle 0.4 (the feasibility computed here says so), so
    all 8 must be reached, the lower leg moving a long way when an upper knee flips."""
    def feasible(side):
        J = JANSEN
        P = jansen_points(0.4)
        C = circles(P["A"], J["j"], P["B"], J["b"], side["tri_bce"])
        D = circles(P["A"], J["k"], P["B"], J["c"], side["linkc"])
        E = circles(P["B"], J["d"], C, J["e"], +1)
        dist = math.hypot(*(E - D))
        return abs(J["f"] - J["g"]) < dist < J["f"] + J["g"], "tri_dfg"
    refused = _check_every_combination(lambda h: jansen_yaml(closure, h), JANSEN_LOOPS,
                                       JANSEN_LENGTHS, JANSEN_GROUND, feasible)
    assert refused == 0


@pytest.mark.parametrize("closure", ("revolute", "distance"))
def test_jansen_walks_a_full_turn(closure):
    """The plain assembly is the walking one (the knees as in the published drawing) and runs a
    whole crank turn with every link length kept."""
    res = planarkin.solve(planarkin.load("j.yaml", text=jansen_yaml(closure)))
    assert res.status == 0, res.message
    P = jansen_points(0.4)
    for name in "ACDEFG":
        p = res.point(name)
        assert math.hypot(p["x"][0] - P[name][0], p["y"][0] - P[name][1]) <= 1e-9
    foot = res.point("G")
    assert foot["y"].min() < -80       # the foot's stride is the lowest part of the leg


# == the Stephenson six-bar ======================================================================

SIX = dict(a=0.04, b=0.12, c=0.10, d=0.10, e5=0.16, e6=0.10, P=(0.06, 0.045), E=(0.18, 0.05))


def six_bar_yaml(closure: str, hints: dict | None = None) -> str:
    """mechanisms/six-bar.yaml (frames as there), or with both loops closed by distance joints:
    no rocker (the coupler's B is kept at c from O4) and no link5 (link6's F kept at e5 from
    the coupler point P)."""
    text = (Path(__file__).resolve().parent.parent / "mechanisms" / "six-bar.yaml").read_text()
    if closure == "distance":
        keep = []
        for ln in text.splitlines():
            if re.match(r"\s+(rocker|link5):", ln) or ("rocker" in ln and "revolute" in ln) \
                    or ("link5" in ln and "revolute" in ln):
                continue
            keep.append(ln)
        text = "\n".join(keep) + "\n"
        text = text.replace("joints:\n", "joints:\n"
                            "  - {type: distance, i: coupler, j: ground, si: [b, 0], sj: [d, 0], "
                            "c: c}\n"
                            "  - {type: distance, i: coupler, j: link6, si: [0.06, 0.045], "
                            "sj: [e6, 0], c: e5}\n")
    text = text.replace("points:\n", "points:\n  A: {body: crank, s: [a, 0]}\n"
                        "  B: {body: coupler, s: [b, 0]}\n  P: {body: coupler, s: [0.06, 0.045]}\n")
    if hints:
        text += "assembly: {branch: {" + ", ".join(f"{k}: '{v}'" for k, v in hints.items()) + \
            "}}\n"
    return text


SIX_LOOPS = {"coupler": ("B", "A", "O4"), "link6": ("F", "P", "E")}
SIX_GROUND = {"O4": (SIX["d"], 0.0), "E": SIX["E"]}
SIX_LENGTHS = [("A", "B", SIX["b"]), ("B", "O4", SIX["c"]), ("P", "F", SIX["e5"]),
               ("F", "E", SIX["e6"])]


@pytest.mark.parametrize("closure", ("revolute", "distance"))
def test_six_bar_every_branch_combination(closure):
    def feasible(side):
        a, b, c, d = SIX["a"], SIX["b"], SIX["c"], SIX["d"]
        A = np.array([a, 0.0])                    # crank angle 0 at t = 0
        B = circles(A, b, (d, 0.0), c, side["coupler"])
        u = (B - A) / b
        P = A + SIX["P"][0] * u + SIX["P"][1] * np.array([-u[1], u[0]])
        dist = math.hypot(*(P - np.asarray(SIX["E"])))
        return abs(SIX["e5"] - SIX["e6"]) < dist < SIX["e5"] + SIX["e6"], "link6"
    refused = _check_every_combination(lambda h: six_bar_yaml(closure, h), SIX_LOOPS,
                                       SIX_LENGTHS, SIX_GROUND, feasible)
    assert refused == 0            # both coupler branches leave the dyad closable (0.146, 0.102 m)


@pytest.mark.parametrize("closure", ("revolute", "distance"))
def test_branch_that_leaves_a_downstream_loop_open_is_refused(closure):
    """With link5 = 0.22 m the dyad spans |e5 - e6| = 0.12 .. 0.32 m: the plain assembly has
    |P - E| = 0.146 m, the coupler's other branch puts P at 0.102 m from E (computed above in
    test_six_bar_every_branch_combination's geometry), where the dyad cannot close: refused, the
    message naming the loop that cannot close, never the plain assembly with the hint ignored."""
    text = six_bar_yaml(closure).replace("e5: 0.16", "e5: 0.22")
    plain = planarkin.solve(planarkin.load("six.yaml", text=text), end=0.01, steps=1)
    assert plain.status == 0, plain.message
    other = "-" if _loop_sign(plain, "coupler") == "+" else "+"
    hinted = text + f"assembly: {{branch: {{coupler: '{other}'}}}}\n"
    with pytest.raises(planarkin.InputError) as exc:
        planarkin.solve(planarkin.load("six.yaml", text=hinted), end=0.01, steps=1)
    msg = str(exc.value)
    assert re.search(r"six\.yaml:\d+: error: assembly: branch: the loop (link5\+)?link6 cannot be "
                     rf"closed at t = 0 on either branch once coupler: \{other} is reached", msg), msg
    assert msg.count("error:") == 1


WORDS = re.compile(r"([+-]): (the [\w-]+ (?:pin|end of the [\w-]+ distance)) (left|right) of the "
                   r"line from (the [\w-]+ (?:pin|end of the [\w-]+ distance)) to "
                   r"(the [\w-]+ (?:pin|end of the [\w-]+ distance)); ([+-]): (left|right) of it")

SIX_LABELS = {"the coupler-rocker pin": "B", "the crank-coupler pin": "A",
              "the ground-rocker pin": "O4", "the coupler end of the coupler-ground distance": "B",
              "the ground end of the coupler-ground distance": "O4",
              "the link5-link6 pin": "F", "the coupler-link5 pin": "P", "the ground-link6 pin": "E",
              "the link6 end of the coupler-link6 distance": "F",
              "the coupler end of the coupler-link6 distance": "P"}


def _check(path):
    """`planarkin check path`, in process (the subprocess form is tested in test_cli.py and
    once below)."""
    from click.testing import CliRunner
    from planarkin.cli import main
    r = CliRunner().invoke(main, ["check", str(path)])
    return type("Done", (), {"returncode": r.exit_code, "stdout": r.output, "stderr": r.output})


def test_check_words_in_a_subprocess(tmp_path):
    p = tmp_path / "six.yaml"
    p.write_text(six_bar_yaml("revolute"))
    cp = run_cli("check", p)
    assert cp.returncode == 0, cp.stderr
    assert len(WORDS.findall(cp.stdout)) == 2, cp.stdout


@pytest.mark.parametrize("closure", ("revolute", "distance"))
def test_check_says_what_each_sign_means(tmp_path, closure):
    """`planarkin check` states each loop's sign as the side of a knee relative to a line; the
    statement is verified against the assembled points (cross product), for the plain assembly
    and with both loops asked for their other sign."""
    p = tmp_path / "six.yaml"
    p.write_text(six_bar_yaml(closure))
    for round_ in range(2):
        cp = _check(p)
        assert cp.returncode == 0, cp.stderr
        found = WORDS.findall(cp.stdout)
        assert len(found) == 2, cp.stdout
        res = planarkin.solve(planarkin.load("six.yaml", text=p.read_text()), end=0.01, steps=1)
        signs = {}
        for sign, knee, side, a, b, other, other_side in found:
            assert {sign, other} == {"+", "-"} and {side, other_side} == {"left", "right"}
            K, A, B = (SIX_LABELS[x] for x in (knee, a, b))
            loop = next(k for k, v in SIX_LOOPS.items() if v[0] == K)
            got = _sides(res, {loop: (K, A, B)}, SIX_GROUND)[loop]
            assert got == (1 if side == "left" else -1), (cp.stdout, got)
            signs[loop] = sign
            assert _loop_sign(res, loop) == sign
        if round_ == 0:       # ask for the other branch of both loops and check again
            flip = {k: "-" if v == "+" else "+" for k, v in signs.items()}
            p.write_text(six_bar_yaml(closure, flip))


@pytest.mark.slow
def test_branch_hint_in_a_large_model():
    """Models past the dense limit (n > 3000) are assembled block by block; a hint is applied
    there too (it was ignored). The IFToMM A02 chain of N = 500 parallelograms (n = 3003),
    the middle loop asked for its other sign: its knee (the pin of k250 on c251) is on the
    other side of the line from c500's tip to c501's pivot, checked by a cross product; every
    loop after it is re-assembled (the residual of every equation stays at rounding)."""
    sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "benchmarks"))
    import models
    from planarkin.assembly import assemble
    N = 500
    plain = planarkin.load("chain.yaml", text=models.chain_yaml(N))
    A0 = assemble(plain)
    key = f"k{N // 2}"
    sign0 = next(m.sign for m in A0.modes if key in m.bodies)
    want = "-" if sign0 > 0 else "+"
    cm = planarkin.load("chain.yaml",
                        text=models.chain_yaml(N) + f"assembly: {{branch: {{{key}: '{want}'}}}}\n")
    A = assemble(cm)
    assert next(m.sign for m in A.modes if key in m.bodies) == (1 if want == "+" else -1)
    assert A.residual <= 1e-10

    def side(q):
        j = N // 2
        th_j = q[3 * cm.body_names.index(f"c{j}") + 2]
        th_k = q[3 * cm.body_names.index(f"c{j + 1}") + 2]
        a = np.array([j + math.cos(th_j), math.sin(th_j)])          # c_j's tip (unit cranks)
        o = np.array([j + 1.0, 0.0])                                 # c_{j+1}'s pivot
        knee = o + np.array([math.cos(th_k), math.sin(th_k)])
        return np.sign(cross(o - a, knee - a))
    assert side(A.q) == -side(A0.q) != 0


def test_two_bodies_of_one_loop_asking_different_signs_refused():
    text = six_bar_yaml("revolute", {"coupler": "+", "rocker": "-"})
    with pytest.raises(planarkin.InputError) as exc:
        planarkin.solve(planarkin.load("six.yaml", text=text), end=0.01, steps=1)
    assert re.fullmatch(r"six\.yaml:\d+: error: assembly: branch: rocker and coupler are in the "
                        r"same loop coupler\+rocker but ask for different signs; give one of them",
                        str(exc.value).strip()), str(exc.value)
