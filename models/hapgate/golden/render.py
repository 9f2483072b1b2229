"""Local contact rendering in the gateware (issue 37): bit-exact model of rtl/render/hg_render.v,
the float truth of the same law in SI units, and the firmware's conversion between them.

The law (per frame strobe k, joints i = 0..2; all sums over the three joints)
-----------------------------------------------------------------------------
A wall with outward normal n, touched at depth d0 at the reference pose q0 (the servo tick's),
linearised in joint space with g = J^T n (m/rad): depth d(q) = d0 - g.(q - q0), rate -g.qdot;
a diagonal joint spring ks about q0. In SI (`truth_torque`):

    fK = K d                      the wall's elastic force (N); contact while fK > 0
    f  = fK - B g.qdot            with its damping (N)
    F  = f if fK > 0 and f > 0 else 0          (a wall pushes, never pulls: hg_walls.c, hg_scene.c)
    tau_i = g_i F - ks_i (q_i - q0_i)          (N m)

The block computes the same law on integers (`contact`), from words the firmware loads:

    e_i = sat(p_i - p0_i)         p: POS_HOMED (32-bit counts, 2^20/rev), wrapped difference
    v_i = sat(vel_i)              VEL: counts per 2^VEL_LOG2W samples (the FIR's or observer's)
    fK  = F0 + sum A_i e_i                                   (exact integers, unit 2^-12 code)
    f   = fK + sum C_i v_i
    F   = min(floor(f / 2^12), 2^17 - 1) if fK > 0 and f >= 0 else 0     (code at G = 1)
    r_i = sat17(floor((2^11 + G_i F + S_i e_i) / 2^12))     (round half up; torque code)
    m_torque_i = clamp(torque_i + r_i, -L_i, min(L_i, 32767)), L_i = min(TQ_LIMIT_i, 32768)

sat() is the symmetric data range +-(2^17 - 1); sat17 is +-65535 (beyond it the sum's clamp
gives the same word for any firmware torque). The words (`Model`; 16 of 32 bits per bank):

| word | name | format | unit | in SI (`quantise`) |
|---|---|---|---|---|
| 0..2 | A_i | signed 24, 12 fraction bits | code per count | -K g_i kappa g_ref / T |
| 3..5 | C_i | signed 24, 12 fraction bits | code per VEL LSB | -B g_i nu g_ref / T |
| 6..8 | G_i | signed 24, 12 fraction bits | 1 | g_i / g_ref |
| 9..11 | S_i | signed 24, 12 fraction bits | code per count | -ks_i kappa / T |
| 12..14 | p0_i | 32 bits | count | q0_i |
| 15 | F0 | signed 32 | 2^-12 code | K d0 g_ref / T |

kappa = 2 pi / 2^20 rad per count, nu = kappa SAMPLE_HZ / 2^VEL_LOG2W rad/s per VEL LSB,
T = torque per code (0.48 N m / 32767), g_ref = the lever F is counted at (the firmware's
choice: max |g_i|, so that |G_i| <= 1 and F is the largest joint's torque). A coefficient's upper
8 bits are ignored. F has the unit "torque code at G = 1".

Control (per clock; `live_frames` is its frame-level form)
----------------------------------------------------------
- `ctl_load` (with `ctl_ttl`) commits the shadow bank: the load is taken at the first frame strobe
  at or after its clock (a load in a strobe's clock is taken by that strobe). Words are written
  into the shadow bank (`cfg_we`) and the banks swap when a load is taken, so a load needs the
  whole model written since the previous take.
- A model taken at strobe t renders the frames of strobes t, t + 1, ..., t + TTL - 1; the strobe
  t + TTL (with no new load taken) expires it: from the clock after that strobe `m_render` is 0
  until a load is taken again. TTL = 0 renders nothing.
- `ctl_zero` (the fault path): `m_torque` is 0 in every clock it is high; it drops the model and
  a waiting load (from the next clock `m_render` is 0), ignores loads and strobes while high;
  rendering resumes only with a load taken after it.
- A strobe starts the computation (restarting one in progress: its result is never shown).
  `m_valid` is high in the clock LATENCY = 3 + 12 (18 / MUL_DIGIT + 3) clocks after the strobe's
  clock; `m_render` shows the frame's result from that clock (all three axes at once) and holds it
  to the next result, expiry or zero.

Frame level (`live_frames`): per strobe k, take[k] = a load is taken at k, kill[k] = a `ctl_zero`
pulse between strobe k - 1 and strobe k that came before that load. Then with t = the last take
<= k and z = the last kill <= k: live[k] = t >= z and k - t < TTL[t].

Error against the float truth (`budget`; the tests assert it per frame and axis)
-------------------------------------------------------------------------------
With the inputs exactly representable (integer counts and VEL LSB), the error comes from the
words' rounding (1/2 LSB = 2^-13 of their unit), the floor of F and the rounding of r:

    eps_f  = 2^-13 (1 + sum |e_j| + sum |v_j|)     (F0 + A e + C v against K d - B g.qdot, codes)
    |dF|   <= 1 + eps_f                            (the floor: [0, 1) code, then the rounding)
    |dr_i| <= 1/2 + (|g_i/g_ref| + 2^-13)(1 + eps_f) + 2^-13 |F| + 2^-13 |e_i|

It holds where neither side saturates (F < 2^17 - 1, |r| < 65535, F0 in its 32 bits) and where
the contact gate agrees: frames with |fK| <= eps_K = 2^-13 (1 + sum |e_j|) codes are exempt (a
gate that flips there moves F by the damping term, as a real wall's contact instant does).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field, replace

import numpy as np

from ..base.block import Block, Params

XW = 18                       # data operand bits (e, v, F)
CW = 24                       # coefficient bits
FRAC = 12                     # coefficient fraction bits
X_MAX = (1 << (XW - 1)) - 1   # 131071: e and v saturate symmetrically
F_MAX = X_MAX                 # the force saturates at 2^17 - 1
R_MAX = (1 << 16) - 1         # 65535: the rendered torque saturates symmetrically
F0_MIN, F0_MAX = -(1 << 31), (1 << 31) - 1
W_A, W_C, W_G, W_S, W_P0, W_F0 = 0, 3, 6, 9, 12, 15
N_WORDS = 16
TORQUE_FS_NM = 0.48           # the firmware's full scale: code 32767 (dsp-fw hg_motor_code)
TORQUE_FS_CODE = 32767


@dataclass(frozen=True)
class RenderConfig:
    clk_hz: int = 48_000_000
    frame_ns: int = 16000
    mul_digit: int = 18       # data bits per multiply clock: 18 (DSP) or 1, 2, 3, 6, 9 (LUTs)
    ttl_bits: int = 16

    @property
    def digits(self) -> int:
        return XW // self.mul_digit

    @property
    def latency(self) -> int:
        """Clocks from the s_frame clock to the m_valid clock."""
        return 3 + 12 * (self.digits + 3)

    @property
    def frame_clocks(self) -> int:
        return self.clk_hz // 1000 * self.frame_ns // 1_000_000

    def refusal(self) -> str | None:
        """The RTL's elaboration error for this configuration, or None."""
        if not 1 <= self.mul_digit <= XW or XW % self.mul_digit:
            return "hg_render_MUL_DIGIT_must_divide_18"
        if not 1000 <= self.clk_hz <= 134_000_000:
            return "hg_render_CLK_HZ_must_be_1kHz_to_134MHz"
        if self.latency > self.frame_clocks:
            return "hg_render_LATENCY_must_fit_in_one_frame"
        if not 1 <= self.ttl_bits <= 24:
            return "hg_render_TTL_BITS_must_be_1_to_24"
        return None

    def rtl_params(self) -> Params:
        return {"CLK_HZ": self.clk_hz, "FRAME_NS": self.frame_ns,
                "MUL_DIGIT": self.mul_digit, "TTL_BITS": self.ttl_bits}

    def to_json(self) -> dict[str, object]:
        return {k: getattr(self, k) for k in self.__dataclass_fields__}

    @classmethod
    def from_json(cls, d: Mapping[str, object]) -> RenderConfig:
        return cls(**d)  # type: ignore[arg-type]

    def with_(self, **kw: object) -> RenderConfig:
        return replace(self, **kw)  # type: ignore[arg-type]


def blocks() -> list[Block]:
    return [Block(name="hg_render", top="hg_render", sources=("render/hg_render.v",),
                  params=lambda: RenderConfig().rtl_params(),
                  doc="local contact model (wall + joint spring) at the frame rate, with TTL")]


# ---------------------------------------------------------------------------- words

@dataclass
class Model:
    """Loaded models, one row each: coefficients as their integer words (value * 2^12)."""
    a: np.ndarray      # (n, 3)
    c: np.ndarray      # (n, 3)
    g: np.ndarray      # (n, 3)
    s: np.ndarray      # (n, 3)
    p0: np.ndarray     # (n, 3) counts (32-bit)
    f0: np.ndarray     # (n,)   2^-12 code

    def words(self) -> np.ndarray:
        """The 16 words per model as unsigned 32-bit values, shape (n, 16)."""
        m32 = (1 << 32) - 1
        cols = [self.a, self.c, self.g, self.s, self.p0]
        w = np.concatenate([np.asarray(x, dtype=np.int64) for x in cols]
                           + [np.asarray(self.f0, dtype=np.int64)[:, None]], axis=1)
        return w & m32

    @classmethod
    def from_words(cls, words: np.ndarray) -> Model:
        """Parse words (n, 16) as the RTL reads them (a coefficient's upper 8 bits ignored)."""
        w = np.asarray(words, dtype=np.int64) & ((1 << 32) - 1)
        coef = sign_extend(w[:, :12], CW)
        full = sign_extend(w[:, 12:], 32)
        return cls(coef[:, 0:3], coef[:, 3:6], coef[:, 6:9], coef[:, 9:12], full[:, 0:3],
                   full[:, 3])


def sign_extend(x: np.ndarray, bits: int) -> np.ndarray:
    m = (1 << bits) - 1
    x = np.asarray(x, dtype=np.int64) & m
    return np.where(x >> (bits - 1), x - (1 << bits), x)


def sat_x(x: np.ndarray) -> np.ndarray:
    """A 32-bit input (wrapped to signed) clamped to +-(2^17 - 1)."""
    return np.clip(sign_extend(x, 32), -X_MAX, X_MAX)


# ---------------------------------------------------------------------------- bit-exact model

def contact(model: Model, pos: np.ndarray, vel: np.ndarray
            ) -> tuple[np.ndarray, np.ndarray]:
    """(F (n,), r (n, 3)): the force and the rendered torque of each frame, model row k with
    frame k (positions and velocities as the 32-bit port values)."""
    e = sat_x(np.asarray(pos, dtype=np.int64) - model.p0)
    v = sat_x(vel)
    fk = model.f0 + (model.a * e).sum(axis=1)
    f = fk + (model.c * v).sum(axis=1)
    force = np.where((fk > 0) & (f >= 0), np.minimum(f >> FRAC, F_MAX), 0)
    acc = (1 << (FRAC - 1)) + model.g * force[:, None] + model.s * e
    return force, np.clip(acc >> FRAC, -R_MAX, R_MAX)


def live_frames(take: np.ndarray, ttl: np.ndarray, kill: np.ndarray | None = None
                ) -> tuple[np.ndarray, np.ndarray]:
    """Per strobe: (live, index of the take whose model renders it, -1 before the first).
    take[k]: a load is taken at strobe k, with TTL ttl[k]; kill[k]: a ctl_zero pulse between
    strobes k - 1 and k, before that load."""
    take = np.asarray(take, dtype=bool)
    n = take.shape[0]
    idx = np.arange(n)
    t = np.maximum.accumulate(np.where(take, idx, -1))
    z = (np.maximum.accumulate(np.where(np.asarray(kill, dtype=bool), idx, -1))
         if kill is not None else np.full(n, -1))
    ttl_t = np.where(t >= 0, np.asarray(ttl, dtype=np.int64)[np.maximum(t, 0)], 0)
    return (t >= 0) & (t >= z) & (idx - t < ttl_t), t


def render_frames(words: np.ndarray, take: np.ndarray, ttl: np.ndarray, pos: np.ndarray,
                  vel: np.ndarray, kill: np.ndarray | None = None
                  ) -> tuple[np.ndarray, np.ndarray]:
    """(live (n,), r (n, 3)): each strobe's result (0 where the model is not live). words[k]:
    the model committed by the load taken at strobe k (rows of other frames are not read)."""
    live, t = live_frames(take, ttl, kill)
    model = Model.from_words(np.asarray(words)[np.maximum(t, 0)])
    _, r = contact(model, pos, vel)
    return live, np.where(live[:, None], r, 0)


def clamp_sum(torque: np.ndarray, render: np.ndarray, limit: np.ndarray) -> np.ndarray:
    """m_torque: the firmware's torque plus the rendered one, clamped like the commutator."""
    lim = np.minimum(np.asarray(limit, dtype=np.int64), 32768)
    s = np.asarray(torque, dtype=np.int64) + np.asarray(render, dtype=np.int64)
    return np.clip(s, -lim, np.minimum(lim, 32767))


# ---------------------------------------------------------------------------- float truth

@dataclass(frozen=True)
class Scales:
    """The units the firmware converts with (defaults: the paper's encoder, 1 MSPS, the window
    FIR's 2^8 samples and the firmware's 0.48 N m full-scale torque code)."""
    counts_per_rev: int = 1 << 20
    sample_hz: int = 1_000_000
    vel_log2w: int = 8
    nm_per_code: float = TORQUE_FS_NM / TORQUE_FS_CODE

    @property
    def rad_per_count(self) -> float:
        return 2 * np.pi / self.counts_per_rev

    @property
    def rad_s_per_vel(self) -> float:
        return self.rad_per_count * self.sample_hz / (1 << self.vel_log2w)


@dataclass
class Contact:
    """Contacts in SI, one row each: wall (g = J^T n, m/rad; K N/m; B N s/m; depth d0 m at the
    reference pose q0, given in counts), joint springs ks (N m/rad), and g_ref (m/rad)."""
    g: np.ndarray      # (n, 3)
    k: np.ndarray      # (n,)
    b: np.ndarray      # (n,)
    d0: np.ndarray     # (n,)
    q0: np.ndarray     # (n, 3) counts
    ks: np.ndarray     # (n, 3)
    g_ref: np.ndarray = field(default_factory=lambda: np.ones(1))  # (n,) or broadcast


def truth_torque(ct: Contact, pos: np.ndarray, vel: np.ndarray, sc: Scales = Scales()
                 ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(tau (n, 3) N m, F (n,) N, fK (n,) N) of the law in SI at the joint angles of `pos`
    (counts, relative to q0 with the 32-bit wrap) and the rates of `vel` (VEL LSB)."""
    dq = sign_extend(np.asarray(pos, dtype=np.int64) - ct.q0, 32) * sc.rad_per_count
    qd = sign_extend(vel, 32) * sc.rad_s_per_vel
    g = np.asarray(ct.g, dtype=np.float64)
    fk = ct.k * (ct.d0 - (g * dq).sum(axis=1))
    f = fk - ct.b * (g * qd).sum(axis=1)
    force = np.where((fk > 0) & (f > 0), f, 0.0)
    return g * force[:, None] - ct.ks * dq, force, fk


def quantise(ct: Contact, sc: Scales = Scales()) -> Model:
    """The firmware's conversion of SI contacts into words (round to nearest; F0 saturates to its
    32 bits). Raises ValueError naming the word if a coefficient is outside its 24 bits."""
    t = sc.nm_per_code
    g = np.asarray(ct.g, dtype=np.float64)
    g_ref = np.broadcast_to(np.asarray(ct.g_ref, dtype=np.float64), (g.shape[0],))[:, None]
    k = np.asarray(ct.k, dtype=np.float64)[:, None]
    b = np.asarray(ct.b, dtype=np.float64)[:, None]
    scale = float(1 << FRAC)
    words = {"A": np.rint(-k * g * sc.rad_per_count * g_ref / t * scale),
             "C": np.rint(-b * g * sc.rad_s_per_vel * g_ref / t * scale),
             "G": np.rint(g / g_ref * scale),
             "S": np.rint(-np.asarray(ct.ks, dtype=np.float64) * sc.rad_per_count / t * scale)}
    lim = 1 << (CW - 1)
    for name, w in words.items():
        bad = np.argwhere((w < -lim) | (w >= lim))
        if bad.size:
            r, i = bad[0]
            raise ValueError(f"render word {name}{i} of contact {r}: {w[r, i]:.0f} is outside "
                             f"the signed {CW}-bit range")
    f0 = np.rint(np.asarray(ct.k) * np.asarray(ct.d0) * g_ref[:, 0] / t * scale)
    return Model(*(words[n].astype(np.int64) for n in "ACGS"),
                 np.asarray(ct.q0, dtype=np.int64),
                 np.clip(f0, F0_MIN, F0_MAX).astype(np.int64))


def budget(ct: Contact, pos: np.ndarray, vel: np.ndarray, sc: Scales = Scales()
           ) -> tuple[np.ndarray, np.ndarray]:
    """(bound (n, 3) in torque codes, exempt (n,)): the error bound of r against the truth in
    codes (module docstring), and the frames where the contact gate may differ."""
    e = np.abs(sign_extend(np.asarray(pos, dtype=np.int64) - ct.q0, 32)).astype(np.float64)
    v = np.abs(sign_extend(vel, 32)).astype(np.float64)
    h = 2.0 ** -(FRAC + 1)
    g = np.asarray(ct.g, dtype=np.float64)
    g_ref = np.broadcast_to(np.asarray(ct.g_ref, dtype=np.float64), (g.shape[0],))
    _, force, fk = truth_torque(ct, pos, vel, sc)
    to_code = g_ref / sc.nm_per_code                 # N -> code at G = 1
    eps_f = h * (1 + e.sum(axis=1) + v.sum(axis=1))
    eps_k = h * (1 + e.sum(axis=1))
    bound = (0.5 + (np.abs(g / g_ref[:, None]) + h) * (1 + eps_f)[:, None]
             + h * (force * to_code)[:, None] + h * e)
    return bound, np.abs(fk * to_code) <= eps_k


# ---------------------------------------------------------------------------- stimulus

def random_model(rng: np.random.Generator, n: int) -> Model:
    """Random words over their whole formats, each row at its own scale (log-uniform), so that
    contact and none, forces inside and beyond F's range, small and saturated torques all
    occur, with the formats' extremes now and then."""
    def coef(lo: float, hi: float) -> np.ndarray:
        scale = np.exp2(rng.uniform(lo, hi, (n, 1)))
        return np.clip(np.rint(rng.standard_normal((n, 3)) * scale), -(1 << 23),
                       (1 << 23) - 1).astype(np.int64)
    a = coef(6, 22)
    a[rng.random((n, 3)) < 0.03] = -(1 << 23)
    c = coef(4, 20)
    g = coef(8, 14)
    g[rng.random((n, 3)) < 0.03] = (1 << 23) - 1
    s = coef(4, 18)
    s[rng.random((n, 3)) < 0.3] = 0
    p0 = rng.integers(-(1 << 31), 1 << 31, (n, 3))
    f0 = rng.choice([-1, 1], n) * np.exp2(rng.uniform(8, 31, n))
    return Model(a, c, g, s, p0, np.clip(np.rint(f0), F0_MIN, F0_MAX).astype(np.int64))


def random_contacts(rng: np.random.Generator, n: int, sc: Scales = Scales()
                    ) -> tuple[Contact, np.ndarray, np.ndarray]:
    """(contacts, pos, vel): walls and springs of the device's scale (links of 0.05 m:
    |g| <= 0.1 m/rad), K from 100 to 50 000 N/m log-uniform, B to 30 N s/m, ks to 5 N m/rad,
    one frame each within 3000 counts of q0 (log-uniform) at up to 3000 VEL LSB (70 rad/s)."""
    g = rng.uniform(-0.1, 0.1, (n, 3)) * (rng.random((n, 3)) > 0.1)
    g[:, 0] = np.where(np.abs(g).max(axis=1) < 0.01, 0.05, g[:, 0])
    g_ref = np.abs(g).max(axis=1)
    k = np.exp(rng.uniform(np.log(100), np.log(50_000), n))
    b = rng.uniform(0, 30, n) * (rng.random(n) > 0.2)
    ks = rng.uniform(0, 5, (n, 3)) * (rng.random((n, 3)) > 0.5)
    f0_code = rng.uniform(-4e4, 1e5, n)                  # the force at q0, code at G = 1
    d0 = f0_code * sc.nm_per_code / (k * g_ref)
    q0 = rng.integers(-(1 << 31), 1 << 31, (n, 3))
    e = rng.choice([-1, 1], (n, 3)) * np.exp(rng.uniform(0, np.log(3000), (n, 3))).astype(int)
    v = rng.choice([-1, 1], (n, 3)) * np.exp(rng.uniform(0, np.log(3000), (n, 3))).astype(int)
    m32 = (1 << 32) - 1
    return Contact(g, k, b, d0, q0, ks, g_ref), (q0 + e) & m32, v & m32


def truth_check(ct: Contact, pos: np.ndarray, vel: np.ndarray, r: np.ndarray,
                sc: Scales = Scales()) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(|r - truth| in codes, budget, frames checked) for rendered torques r (n, 3) of the
    contacts at those inputs: checked where neither side saturates and the contact gate cannot
    differ (module docstring)."""
    tau, force, _ = truth_torque(ct, pos, vel, sc)
    want = tau / sc.nm_per_code
    bound, exempt = budget(ct, pos, vel, sc)
    g_ref = np.broadcast_to(np.asarray(ct.g_ref, dtype=np.float64), (want.shape[0],))
    f0 = quantise(ct, sc).f0
    e = np.abs(sign_extend(np.asarray(pos, dtype=np.int64) - ct.q0, 32)).sum(axis=1)
    v = np.abs(sign_extend(vel, 32)).sum(axis=1)
    f_top = force * g_ref / sc.nm_per_code + 2.0 ** -(FRAC + 1) * (1 + e + v)   # F's largest
    ok = (~exempt & (f_top < F_MAX)
          & np.all(np.abs(r) < R_MAX, axis=1) & np.all(np.abs(want) < R_MAX - bound, axis=1)
          & (f0 > F0_MIN) & (f0 < F0_MAX))
    return np.abs(np.asarray(r) - want), bound, ok

