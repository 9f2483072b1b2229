"""Local contact rendering (rtl/render/hg_render.v, issue 37): bit-exact against the integer model
on every frame (both simulators, the LUT-only 12 MHz and the DSP 48 MHz configurations), the
error of the integer law against the float truth within the budget derived in
hapgate.golden.render, the timing at every clock we ship, and the elaboration refusals."""

from __future__ import annotations

import json
from fractions import Fraction
from pathlib import Path

import numpy as np
import pytest
from hapgate.flows import blocks, flow
from hapgate.golden import render as rd
from hapgate.runners import sim

HERE = Path(__file__).parent
CONFIGS = {
    "hx8k_12m_d3": rd.RenderConfig(clk_hz=12_000_000, mul_digit=3),   # LUT-only, 12 MHz board
    "ecp5_48m_d18": rd.RenderConfig(),                                 # one product a clock
}
# The clocks we ship (the HX8K's 12 MHz, the ECP5's and the default's 48 MHz) and the 24 MHz the
# converter timing also runs at; the frame the output must be ready in (docs/design/SPEC.md).
SHIPPED_HZ = (12_000_000, 24_000_000, 48_000_000)
FRAME_S = Fraction(16, 10**6)


def spec_latency(mul_digit: int) -> int:
    """rtl/render/README.md, "Timing": m_valid 3 + 12 (18 / MUL_DIGIT + 3) clocks after the
    clock of s_frame (12 products, each: read p0, read the coefficient, the digits, accumulate)."""
    return 3 + 12 * (18 // mul_digit + 3)


def _run(simulator: str, cfg: rd.RenderConfig, tests: list[str], **env: str) -> None:
    assert cfg.latency < cfg.frame_clocks - 1     # the testbench samples at the frame's end
    sim.run_cocotb(blocks.get("hg_render"), simulator, "cocotb_render", HERE,
                   params=cfg.rtl_params(), testcase=tests,
                   extra_env={"HG_MODEL": json.dumps(cfg.to_json()), **env})


@pytest.mark.parametrize("simulator", sim.simulators())
@pytest.mark.parametrize("name", list(CONFIGS))
def test_render_rtl(simulator: str, name: str) -> None:
    """Every frame's result and end-of-frame output bit-exact (random and corner stimulus), and
    the RTL's own results against the float truth within the budget."""
    frames = "240" if simulator == "verilator" else "80"
    _run(simulator, CONFIGS[name], ["random_bit_exact", "corners", "truth"], HG_FRAMES=frames)


@pytest.mark.parametrize("clk_hz", SHIPPED_HZ)
@pytest.mark.parametrize("mul_digit", (3, 18))
def test_timing_at_shipped_clocks(clk_hz: int, mul_digit: int) -> None:
    """The latency (the spec's formula, not the configuration's), within one frame; expiry and
    the zero input at the clock, in simulation time."""
    cfg = rd.RenderConfig(clk_hz=clk_hz, mul_digit=mul_digit)
    lat = spec_latency(mul_digit)
    assert Fraction(lat, clk_hz) <= FRAME_S
    assert cfg.latency == lat
    _run(sim.one_simulator(), cfg, ["timing"], HG_LATENCY=str(lat))


@pytest.mark.parametrize("change, message", [
    ({"MUL_DIGIT": 4}, "hg_render_MUL_DIGIT_must_divide_18"),
    ({"MUL_DIGIT": 0}, "hg_render_MUL_DIGIT_must_divide_18"),
    # 255 clocks bit-serially do not fit the 192 of a 12 MHz frame
    ({"MUL_DIGIT": 1, "CLK_HZ": 12_000_000}, "hg_render_LATENCY_must_fit_in_one_frame"),
    # the edge: 111 clocks at MUL_DIGIT 3 in a 111-clock frame fit, in a 110-clock one not
    ({"MUL_DIGIT": 3, "CLK_HZ": 12_000_000, "FRAME_NS": 9249},
     "hg_render_LATENCY_must_fit_in_one_frame"),
    ({"TTL_BITS": 0}, "hg_render_TTL_BITS_must_be_1_to_24"),
])
def test_bad_configuration_fails_at_elaboration(change: dict[str, int], message: str) -> None:
    block = blocks.get("hg_render")
    params = {**block.params(), **change}
    f = flow.lint_verilator(block, params)
    assert not f.ok and message in f.detail, f.detail
    g = flow.lint_icarus(block, params)
    assert not g.ok and message in g.detail, g.detail
    model = rd.RenderConfig(clk_hz=params["CLK_HZ"], frame_ns=params["FRAME_NS"],  # type: ignore[arg-type]
                            mul_digit=params["MUL_DIGIT"], ttl_bits=params["TTL_BITS"])  # type: ignore[arg-type]
    assert model.refusal() == message


def test_configurations_at_the_edge_are_accepted() -> None:
    block = blocks.get("hg_render")
    for change in ({"MUL_DIGIT": 3, "CLK_HZ": 12_000_000, "FRAME_NS": 9250},   # 111 in 111
                   {"MUL_DIGIT": 2, "CLK_HZ": 12_000_000},                      # 147 in 192
                   {"MUL_DIGIT": 1, "CLK_HZ": 24_000_000}):                     # 255 in 384
        f = flow.lint_verilator(block, {**block.params(), **change})
        assert f.ok, (change, f.detail)


# ---------------------------------------------------------------------------- model vs truth

def _errors(ct: rd.Contact, pos: np.ndarray, vel: np.ndarray, sc: rd.Scales = rd.Scales()
            ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """(|error| in codes, budget, frames checked, F) of the integer law with words converted
    with `sc` against the truth (in the default units)."""
    f_int, got = rd.contact(rd.quantise(ct, sc), pos, vel)
    err, bound, ok = rd.truth_check(ct, pos, vel, got)
    return err, bound, ok, f_int


def test_model_within_truth_budget() -> None:
    """The integer law against the SI law at the same inputs, per frame and axis: within the
    budget of hapgate.golden.render (rounding of every word, the floor of F, the rounding of r);
    and the budget is tight (the worst frame uses most of it)."""
    rng = np.random.default_rng(37)
    ct, pos, vel = rd.random_contacts(rng, 40_000)
    err, bound, ok, f_int = _errors(ct, pos, vel)
    assert ok.mean() > 0.6, ok.mean()                    # most frames are checked
    assert (f_int[ok] > 0).mean() > 0.3                  # and many are in contact
    ratio = err[ok] / bound[ok]
    assert np.all(ratio <= 1.0), (ratio.max(), np.argwhere(err / bound > 1)[:3])
    assert ratio.max() > 0.5, ratio.max()
    print(f"checked {ok.sum()} of {len(ok)} frames; max |err| {err[ok].max():.3f} codes, "
          f"RMS {np.sqrt(np.mean(err[ok] ** 2)):.3f}; worst err/budget {ratio.max():.3f}; "
          f"budget median {np.median(bound[ok]):.2f} max {bound[ok].max():.2f} codes")


def test_truth_check_fails_on_a_wrong_conversion() -> None:
    """The budget check can fail: words converted with the velocity unit of a 2^7-sample window
    (twice the damping), or with the spring's sign flipped, leave it."""
    rng = np.random.default_rng(38)
    ct, pos, vel = rd.random_contacts(rng, 4000)
    for wrong in (rd.Scales(vel_log2w=7),):
        err, bound, ok, _ = _errors(ct, pos, vel, wrong)
        assert np.any(err[ok] > bound[ok])
    flipped = rd.Contact(ct.g, ct.k, ct.b, ct.d0, ct.q0, -ct.ks, ct.g_ref)
    model = rd.quantise(flipped)
    _, got = rd.contact(model, pos, vel)
    tau, _, _ = rd.truth_torque(ct, pos, vel)
    bound, _ = rd.budget(ct, pos, vel)
    assert np.any(np.abs(got - tau / rd.Scales().nm_per_code) > bound)


def test_quantise_refuses_a_word_out_of_range() -> None:
    """A wall too stiff for the A words' 24 bits (2048 codes per count) is refused, by name."""
    sc = rd.Scales()
    k = 2048.5 * sc.nm_per_code / (0.1 * 0.1 * sc.rad_per_count)     # A = -2048.5 codes/count
    ct = rd.Contact(np.array([[0.1, 0, 0]]), np.array([k]), np.array([0.0]), np.array([0.0]),
                    np.zeros((1, 3), dtype=np.int64), np.zeros((1, 3)), np.array([0.1]))
    with pytest.raises(ValueError, match="render word A0 of contact 0"):
        rd.quantise(ct, sc)
    ct.k = np.array([k * 2047.9 / 2048.5])
    assert rd.quantise(ct, sc).a[0, 0] == round(-2047.9 * 4096)


# ---------------------------------------------------------------------------- model, literal

def test_words_round_trip_and_coefficient_top_bits_ignored() -> None:
    rng = np.random.default_rng(1)
    m = rd.random_model(rng, 500)
    w = m.words()
    assert w.shape == (500, 16) and np.all((w >= 0) & (w < 1 << 32))
    junk = w.copy()
    junk[:, :12] = (junk[:, :12] & 0xFFFFFF) | (rng.integers(0, 256, (500, 12)) << 24)
    for words in (w, junk):
        back = rd.Model.from_words(words)
        for f in ("a", "c", "g", "s", "p0", "f0"):
            assert np.array_equal(getattr(back, f), getattr(m, f)), f


def test_live_frames_literal() -> None:
    """The README's TTL rule: a model taken at t renders t .. t + TTL - 1; a zero pulse before
    a frame's strobe drops it; a load after the pulse in the same interval renders."""
    take = np.array([1, 0, 0, 0, 0, 1, 0, 1, 1, 0, 0, 1, 0, 0], dtype=bool)
    ttl = np.array([3, 0, 0, 0, 0, 0, 0, 5, 2, 0, 0, 4, 0, 0])
    kill = np.zeros(14, dtype=bool)
    kill[[10, 11]] = True
    live, src = rd.live_frames(take, ttl, kill)
    assert live.astype(int).tolist() == [1, 1, 1, 0, 0, 0, 0, 1, 1, 1, 0, 1, 1, 1]
    assert src.tolist() == [0, 0, 0, 0, 0, 5, 5, 7, 8, 8, 8, 11, 11, 11]


def test_contact_literal() -> None:
    """Hand-computed frames of the integer law: contact only while F0 + A e > 0, damping that
    would pull gives 0, F saturates at 2^17 - 1, r rounds half up and saturates at +-65535,
    e wraps around 2^32 before it saturates."""
    one = 4096
    m = rd.Model(a=np.array([[-5 * one, 0, 0]] * 6), c=np.array([[-100 * one, 0, 0]] * 6),
                 g=np.array([[one, one // 2, -one]] * 6), s=np.zeros((6, 3), dtype=np.int64),
                 p0=np.array([[(1 << 32) - 2, 0, 0]] * 6), f0=np.zeros(6, dtype=np.int64))
    pos = np.array([[-4, 0, 0], [-4, 0, 0], [-4, 0, 0], [0, 0, 0], [-3, 0, 0], [-4, 0, 0]])
    vel = np.array([[0, 0, 0], [1, 0, 0], [-1, 0, 0], [-9, 0, 0], [0, 0, 0], [-1 << 20, 0, 0]])
    f, r = rd.contact(m, pos, vel)                        # e0 = -2, -2, -2, 2, -1, -2
    assert f.tolist() == [10, 0, 110, 0, 5, rd.F_MAX]
    assert r[:, 0].tolist() == [10, 0, 110, 0, 5, 65535]
    assert r[:, 1].tolist() == [5, 0, 55, 0, 3, 65535]    # 2.5 -> 3 is the tie: half up
    assert r[:, 2].tolist() == [-10, 0, -110, 0, -5, -65535]
    assert rd.clamp_sum(np.array([[32767, -32768, 100]]), np.array([[1, -1, -65535]]),
                        np.array([[65535, 32768, 20479]])).tolist() == [[32767, -32768, -20479]]
    assert rd.sat_x(np.array([131071, 131072, -131071, -131072, 1 << 31, (1 << 32) - 1])
                    ).tolist() == [131071, 131071, -131071, -131071, -131071, -1]
