"""The interpolator's documented thresholds at their boundaries (issue 29, "Boundaries"): the ADC
clipping rails, both ends of the signal-loss amplitude window, the loss run length and the
overspeed limit. Each case is a healthy input at the last code before the threshold (no fault),
the threshold itself and the first code past it, with the expected fault written from the spec
numbers below (never read from the configuration under test). One native Verilator run (three
axes) carries every case; the bit-exact model gets the same samples, and both must equal the
spec's answer, so model and RTL moving together still fail.

Spec (rtl/interp/README.md, "Algorithm", step 8; docs/design/SPEC.md "Figures from the paper"):
- clipping: "a or b at -128 or +127, on that sample" (ADC codes -128..+127);
- signal loss: "a^2 + b^2 outside [AMP_MIN^2, AMP_MAX^2] = [40^2, 170^2] for LOSS_SAMPLES = 16
  consecutive samples: raised on the 16th";
- overspeed: "all transitions captured up to 244.2 rev/s = 1 MSPS / (4 samples/line x 1024
  lines)"; one quadrant per sample is tracked, a two-quadrant step is the overspeed fault
  (README step 4; "tested: no overspeed at 244.1, flagged at 244.2 rev/s", step 1)."""

from __future__ import annotations

import numpy as np
from hapgate.golden import encsig, interp
from hapgate.runners import native

# fault bits of m_faults (rtl/interp/README.md step 8: bit 0 overspeed, 1 clipping, 2 loss)
OVS, CLIP, LOSS = 1, 2, 4
AMP_MIN2 = 40 ** 2          # README step 8: [40^2, 170^2]
AMP_MAX2 = 170 ** 2
LOSS_RUN = 16               # README step 8: LOSS_SAMPLES = 16, raised on the 16th
LIMIT_REV_S = 1_000_000 / (4 * 1024)   # SPEC.md: 1 MSPS / (4 samples/line x 1024 lines)
HOLD = 20                   # samples per case (> LOSS_RUN)
MID = {0: (70, 70), 1: (70, -70), 2: (-70, -70), 3: (-70, 70)}   # healthy mid-quadrant points


def quadrant(a: int, b: int) -> int:
    """README step 1 for non-zero codes: q = 2 sa + (sa xor sb)."""
    sa, sb = int(a < 0), int(b < 0)
    return 2 * sa + (sa ^ sb)


class Plan:
    """Samples of one axis: each case is preceded by healthy mid-quadrant points that walk one
    quadrant per sample to the case's quadrant (no overspeed on the way, and at least one sample
    inside the window), and a fault clear on its first sample (a clear applies before its
    sample is evaluated)."""

    def __init__(self) -> None:
        self.a: list[int] = []
        self.b: list[int] = []
        self.clear: list[int] = []
        self.want: list[int] = []
        self.cases: list[tuple[str, int, int]] = []     # name, first sample, length
        self.q = 0
        self._healthy(*MID[0])

    def _healthy(self, a: int, b: int) -> None:
        self.a.append(a)
        self.b.append(b)
        self.want.append(-1)                             # not checked (a fault may be sticky)

    def goto(self, q: int) -> None:
        while self.q != q:
            self.q = (self.q + (1 if (q - self.q) % 4 <= 2 else -1)) % 4
            self._healthy(*MID[self.q])

    def case(self, name: str, samples: list[tuple[int, int]], want: list[int]) -> None:
        self.goto(quadrant(*samples[0]))
        self._healthy(*MID[self.q])                      # in the window: the loss run restarts
        k0 = len(self.a)
        self.clear.append(k0)
        for (a, b), w in zip(samples, want, strict=True):
            self.a.append(a)
            self.b.append(b)
            self.want.append(w)
        self.q = quadrant(*samples[-1])
        self.cases.append((name, k0, len(samples)))

    def hold(self, name: str, a: int, b: int, fault: int, first: int = 0, n: int = HOLD) -> None:
        """(a, b) held for n samples; `fault` from the sample `first` of the case on."""
        self.case(name, [(a, b)] * n, [0] * first + [fault] * (n - first))


def level_cases(p: Plan) -> None:
    # clipping rails: +126 and -127 are healthy, +127 and -128 clip on that very sample; each
    # channel, and each rail with the other channel on either sign
    for ch in (0, 1):
        for other in (30, -30):
            for code, fault in ((125, 0), (126, 0), (127, CLIP), (-126, 0), (-127, 0),
                                (-128, CLIP)):
                ab = (code, other) if ch == 0 else (other, code)
                p.hold(f"clip {'ab'[ch]}={code} other={other}", *ab, fault)
    # signal-loss window, lower end: 40^2 = 1600. 1597 and 1601 are the reachable sums next to
    # it (1598 and 1599 are not sums of two squares); (24, 31) and (39, 1) are one code below
    # (24, 32) and (40, 1). Out of the window: loss on the 16th sample, not before.
    low = [((24, 32), 1600), ((32, 24), 1600), ((1, 40), 1601), ((40, 1), 1601),
           ((21, 34), 1597), ((34, 21), 1597), ((24, 31), 1537), ((39, 1), 1522),
           ((40, 0), 1600), ((0, 40), 1600)]
    # upper end: 170^2 = 28900 is not a sum of two 8-bit codes; the nearest reachable sums are
    # 28898 (in) and 29041 (out), which lie between 169^2 and 171^2: they fix the spec's 170.
    high = [((-127, -113), 28898), ((113, -127), 28898), ((120, 121), 29041),
            ((-121, 120), 29041), ((126, 114), 28872), ((126, 126), 31752)]
    for (a, b), s in low + high:
        assert a * a + b * b == s                        # the sums quoted above
        inside = AMP_MIN2 <= s <= AMP_MAX2
        # the low end also in quadrant 2 (|a|, |b|); a zero code holds its sign, so only q0
        for sgn in (1, -1) if s < 10_000 and 0 not in (a, b) else (1,):
            aa, bb = sgn * a, sgn * b
            p.hold(f"window {aa},{bb} (sum {s})", aa, bb, 0 if inside else LOSS,
                   first=LOSS_RUN - 1)
    # the run length: 15 out-of-window samples then one inside: nothing; 16: loss on the 16th
    p.case("loss run 15", [(21, 34)] * (LOSS_RUN - 1) + [(24, 32)] * 4, [0] * (LOSS_RUN + 3))
    p.case("loss run 16", [(21, 34)] * LOSS_RUN + [(24, 32)] * 4,
           [0] * (LOSS_RUN - 1) + [LOSS] * 5)
    # overspeed: one quadrant per sample either way is tracked, two is the fault on that sample
    for q0 in range(4):
        for dq, fault in ((1, 0), (3, 0), (2, OVS)):
            p.case(f"step q{q0} -> q{(q0 + dq) % 4}", [MID[q0], MID[(q0 + dq) % 4]] * 1
                   + [MID[(q0 + dq) % 4]] * 3, [0, fault, fault, fault, fault])


def test_interp_boundaries_model_and_rtl() -> None:
    p = Plan()
    level_cases(p)
    n_lvl = len(p.a)
    # the overspeed limit as a speed: 244.1 rev/s (under the limit) and 244.2 (over it), ideal
    # signals at R = 120 (no clipping). Over the limit, each sample advances 90 deg + 0.02 deg
    # beyond one quadrant, so within 90 / 0.02 = 4.5e3 samples one sample skips a quadrant.
    n = max(60_000, n_lvl + 10)
    spec = encsig.with_spec(encsig.IDEAL, amplitude=120)
    speeds = (244.1, 244.2)                            # README step 1: the tested pair
    assert speeds[0] < LIMIT_REV_S < speeds[1]
    a = np.zeros((n, 3), dtype=np.int64)
    b = np.zeros((n, 3), dtype=np.int64)
    a[:n_lvl, 0], b[:n_lvl, 0] = p.a, p.b
    a[n_lvl:, 0], b[n_lvl:, 0] = MID[p.q]                  # then a healthy standstill
    for ax, v in enumerate(speeds, start=1):
        a[:, ax], b[:, ax] = encsig.adc_codes(encsig.constant(v, n, start=0.1), spec)
    assert np.abs(a[:, 1:]).max() <= 120 and np.abs(b[:, 1:]).max() <= 120
    clear = [p.clear + [n_lvl], [], []]                 # the standstill starts cleared
    rtl = native.run_interp(a, b, None, interp.InterpConfig(), columns=["faults"],
                            clear_at=clear)
    want = np.array(p.want)
    checked = want >= 0
    for ax in range(3):
        model = interp.run(a[:, ax], b[:, ax], None, interp.InterpConfig(),
                           clear_at=clear[ax]).faults
        got = {"rtl": rtl.axis(ax)["faults"], "model": model}
        for engine, f in got.items():
            if ax == 0:
                bad = np.flatnonzero(f[:n_lvl][checked] != want[checked])
                if bad.size:
                    k = int(np.flatnonzero(checked)[bad[0]])
                    name = next(c for c in p.cases if c[1] <= k < c[1] + c[2])
                    raise AssertionError(f"{engine}: case {name[0]!r}, sample {k - name[1]}: "
                                         f"faults {f[k]}, spec {want[k]}")
                assert not f[n_lvl:].any(), engine
            elif ax == 1:                                 # under the limit: never a fault
                assert not f.any(), (engine, speeds[0], int(np.argmax(f != 0)))
            else:                                         # over it: overspeed, nothing else
                first = int(np.argmax(f != 0))
                assert f[-1] == OVS and f[first] == OVS and first <= 4500 + 10, (engine, first)
    print(f"{len(p.cases)} level cases and 2 speeds ({speeds[0]:.4f}, {speeds[1]:.4f} rev/s), "
          f"{n} samples per axis: model and RTL equal the spec on every case")
