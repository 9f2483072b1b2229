// SPDX-License-Identifier: Apache-2.0
// The virtual device, closed loop: the Verilated FPGA top (hapgate_top, built with HG_SIM_GATE
// and, for the scene's AXIS_MASK < 7, the held-axis bank held/enc_interp3.v), the DSP firmware (dsp-fw/src, unchanged) on its ISR and background
// loop over a grid-aligned bus, and the plant (plant.cpp: motors, linkage, hand, encoders).
// Driven by models/hapgate/device/runner.py; description: tb/native/device/README.md.
//
// usage: device_harness PLANT_CFG RUN_CFG OUTDIR [LINK_CFG]   (LINK_CFG: the PC link, uart_link.h)
//
// Built with HG_SOC=1 it is the soc fidelity (README "SoC fidelity"): the Verilated SoC
// (rtl/soc/hapgate_soc_top.v: the soft CPU running the cross-built firmware image, and the same
// hapgate_top) in the same clock loop, plant, scenario and records; the harness runs no firmware
// of its own, reads the firmware's tick observation from the CPU's RAM, and bridges the PC link
// bit by bit on the UART pins.
// Every clock-dependent event is tied to the 1 us sample grid (README "Why any clock gives the
// same result"), so a run is bit-identical at every CLK_HZ >= 6 MHz that the RTL accepts.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <ctime>
#include <fstream>
#include <map>
#include <memory>
#include <sstream>
#include <string>
#include <vector>

#ifndef HG_SOC
#define HG_SOC 0
#endif
#if HG_SOC
#include "Vhapgate_soc_top.h"
#include "Vhapgate_soc_top___024root.h"
#include "Vhapgate_soc_top_hapgate_soc_top.h"   // the public signals (tb/native/soc/public.vlt)
#include "Vhapgate_soc_top_hg_soc.h"
#include "Vhapgate_soc_top_VexRiscv.h"
#else
#include "Vhapgate_top.h"
#include "Vhapgate_top___024root.h"
#endif
#include "bus_hal.h"
#include "dac_word.h"
#include "harness_common.h"
#include "plant.h"
#include "stage_clocks.h"
#include "testb.h"
#include "uart_link.h"
#include "verilated.h"
#include "view_link.h"
#include "../vl_internals.h"
#if HG_FI
#include "fault_inject.h"   // the saboteur netlist's injection ports (issue 38)
#endif

extern "C" {
#include "hg_fpga_regs.h"
#include "hg_hal.h"
#include "hg_link.h"
#include "hg_servo.h"
}
#if HG_SOC
#if HG_SIM_GATE || AXIS_MASK != 7 || HG_FI
#error "the soc fidelity builds hapgate_soc_top as the board does: three axes, no stage clocks, no saboteur"
#endif
using Top = Vhapgate_soc_top;
using Root = Vhapgate_soc_top___024root;
#else
using Top = Vhapgate_top;
using Root = Vhapgate_top___024root;
#endif

#ifndef CLK_HZ
#error "CLK_HZ must be defined to match the RTL parameter"
#endif
#ifndef AXIS_MASK
#error "AXIS_MASK must be defined to match the RTL parameter"
#endif

// The generated model's evaluation phases, called directly in the clock loop:
// Vhapgate_top::eval() adds a message-queue flush and a deleter pass per call (~14 % of the run
// here) that only matter for $display/$finish from other threads; the model has neither. The
// first eval() goes through the public entry (it runs the initial blocks). Bench::eval_edge is
// the generated ___eval loop with three things left out: the input-combinational phase runs
// only when an input other than a clock changed since the last evaluation (it computes the logic
// that reads inputs, whose values are otherwise those of the last evaluation; logic that also
// reads registers is re-evaluated in the NBA phase of their clocks: skipped in ~5 of 6 clocks,
// ~7 % of a run); the active phase is not run (it computes the trigger vector, which clocks
// rose, from the clock inputs and their previous values; but every clock is a top-level input
// this harness drives itself, so Bench::learn_triggers asks the generated trigger function once
// per combination of stage clocks and each edge sets the NBA trigger vector from that table:
// the clock inputs and their previous values are never touched again, nothing else reads them;
// ~5 % of a run); and the NBA phase runs once (no register drives a clock). These internals are
// used only through tb/native/vl_internals.h, which checks the Verilator version.
#if HG_SOC
HG_VL_DECLARE_PHASES(Vhapgate_soc_top);
#else
HG_VL_DECLARE_PHASES(Vhapgate_top);
#endif


namespace {

using hg_dev::kPi;
constexpr uint64_t D = CLK_HZ / 1000000;  // clocks per sample-grid point (1 us)
static_assert(CLK_HZ % 1000000 == 0, "CLK_HZ must be a whole number of MHz");
static_assert(D >= 6, "the grid-aligned bus needs a strobe of >= 5 clocks inside 1 us: CLK_HZ >= 6 MHz");
#ifndef HG_LOAD_CLOCKS
#error "HG_LOAD_CLOCKS (frame start -> channel 0 load, from the top's configuration) must be defined"
#endif
constexpr int kLoadClocks = HG_LOAD_CLOCKS;  // frame start -> channel 0 load (rtl/top/README.md)
constexpr uint64_t kDacDelayUs = 2;        // a word reaches the amplifier 2 us after its slot start

// Cost split (HG_PROFILE=1 in the environment): wall time in the plant, in the firmware's own
// code (its ISR minus the bus accesses, which clock the gateware) and the rest (the gateware and
// the harness). Off by default: the clock reads cost ~2 % of a run.
bool g_profile = false;
double g_plant_s = 0, g_isr_s = 0, g_bus_in_isr_s = 0;
bool g_in_isr = false;
inline double now_s() {
    return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
}

using hg_dev::FrameRec;
using hg_dev::LoadRec;
using hg_dev::RunCfg;


// ------------------------------------------------------------------ the testbench
// The shared wrapper (testb.h: the model, reset, the edge count, the trace) with the virtual
// device's clock loop: its stage clocks, the DAC and irq monitors, the sample grid.
struct Bench : hg_tb::TestB<Top> {
    hg_plant* plant = nullptr;
    RunCfg* cfg = nullptr;
    ViewLink* view = nullptr;     // the live view (off: null)
    int prev_wr_n = 1, prev_irq = 0;
    bool irq_rose = false;
    uint64_t irq_edge = 0;
    // DAC pipeline to the amplifier: (grid us, channel, code)
    struct Pend { uint64_t at_us; int ch; int code; };
    std::vector<Pend> pend;
    int16_t frame_codes[6] = {0, 0, 0, 0, 0, 0};
    hg_dev::RecordFile<LoadRec> loads;
    hg_dev::RecordFile<FrameRec> frames;
    hg_dev::RecordFile<int8_t> adc;       // A0 B0 A1 B1 A2 B2 per grid point of the scene (record bit 2)
    uint32_t skew = 0, frame = 0;  // clocks (from the RTL's DAC_SKEW / DAC_FRAME)
    // grid
    int64_t scene0_us = 0;        // grid point of scene time 0
    bool dynamic = false;         // plant released (scene time 0: the fixture lets go)
    bool dropout[3] = {false, false, false};
    std::vector<double> qtrue_ring;  // true q per grid point (ring), for the snapshot truth
    static constexpr size_t kRing = 4096;

    double scene_t(uint64_t g_us) const { return (static_cast<double>(g_us) - static_cast<double>(scene0_us)) * 1e-6; }

    // At grid point g (edge g*D), after the negedge evaluation. Out of line: tick() (every
    // edge) then needs no registers saved for it and inlines into the clock loop.
    __attribute__((noinline)) void grid(uint64_t g) {
        for (size_t k = 0; k < pend.size();) {
            if (pend[k].at_us <= g) {
                hg_plant_set_dac(plant, pend[k].ch, pend[k].code);
                pend[k] = pend.back();
                pend.pop_back();
            } else {
                ++k;
            }
        }
        hg_plant_q(plant, &qtrue_ring[(g % kRing) * 3]);
        const bool frame_start = frame && (g * D) % frame == 0;
        if (frame_start && dynamic && (cfg->record & 3)) {
            hg_plant_out o;
            hg_plant_read(plant, &o);
            frames.push(hg_dev::frame_record(o, scene_t(g), cfg->record));
        }
        if (view && frame_start && dynamic && view_link_want(view, scene_t(g))) {
            hg_plant_out o;
            hg_plant_read(plant, &o);
            o.t = scene_t(g);
            view_link_frame(view, o, frame_codes);
        }
        // ADC words for the capture at the next edge (sample grid g), then one grid step
        int8_t a[3] = {0, 0, 0}, b[3] = {0, 0, 0};   // an axis that is not built has no signal
        uint8_t ix[3] = {0, 0, 0};
        double tp0 = 0;
        if (g_profile) tp0 = now_s();
        hg_plant_adc_mask(plant, AXIS_MASK, a, b, ix);
        uint32_t wa = 0, wb = 0, wi = 0;
        for (int i = 0; i < 3; ++i) {
            if (dropout[i]) a[i] = b[i] = 0;
            if (dynamic && (cfg->record & 4)) {
                adc.push(a[i]);
                adc.push(b[i]);
            }
            wa |= static_cast<uint32_t>(static_cast<uint8_t>(a[i])) << (8 * i);
            wb |= static_cast<uint32_t>(static_cast<uint8_t>(b[i])) << (8 * i);
            wi |= static_cast<uint32_t>(ix[i]) << i;
        }
        if (view && dynamic && view_link_adc_on(view)) view_link_adc(view, a, b);
        // sampled at the next posedge evaluation; the input-combinational phase runs only if
        // a word changed (at a hand's speeds an encoder's codes stay for several microseconds)
        wi &= 7U;
        if (top->adc_a != wa || top->adc_b != wb || top->enc_index != wi) {
            top->adc_a = wa;
            top->adc_b = wb;
            top->enc_index = static_cast<uint8_t>(wi);
            inputs_changed = true;
        }
        hg_plant_step(plant, steps_per_us);
        if (g_profile) g_plant_s += now_s() - tp0;
    }

    int steps_per_us = 1;
    bool inputs_changed = true;   // an input other than the clocks changed (eval(), below)
#if HG_SOC
    // The SoC's own pins and bus, watched at every edge: the UART (uart_link.h UartPins: the
    // PC's bytes shifted onto uart_rx, uart_tx decoded) and the watchdog's key writes (the
    // bridge's strobe to the WDOG word: the edge its access starts).
    hg_uart::UartPins* uart_pins = nullptr;
    int prev_ce = 1;
    int64_t key_edge = 0;
    __attribute__((always_inline)) void soc_edge(const Root* out) {
        const auto* st = out->hapgate_soc_top;
        const int ce = st->bus_ce_n;
        if (!ce && prev_ce && !st->bus_we_n && st->bus_addr == HG_REG_WDOG) key_edge = static_cast<int64_t>(edge);
        prev_ce = ce;
        if (uart_pins) {
            uint8_t rx = top->uart_rx;
            uart_pins->at(edge, rx, out->uart_tx);
            if (rx != top->uart_rx) {
                top->uart_rx = rx;
                inputs_changed = true;
            }
        }
    }
#endif
#if HG_FI
    hg_fi::Injector fi;           // seu / stuck faults into the flip-flops (fault_inject.h)
#endif


#if !HG_TRACE
    // NBA trigger vector of a rising edge of clk with the stage clocks of gate bits g (README
    // "Stage clocks"), from the generated trigger function (learn_triggers)
    uint64_t trig[hg_dev::kAllGates + 1] = {};

    // Called once, with every clock low (between edges): for each combination of stage clocks,
    // raise them with clk and let the generated code compute its trigger vector
    // (learn_trigger, tb/native/vl_internals.h). Each clock must own one trigger bit of its own, which is checked.
    void learn_triggers() {
        Root* r = top->rootp;
        const unsigned n = HG_SIM_GATE ? hg_dev::kAllGates + 1 : 1;
        for (unsigned g = 0; g < n; ++g) {
            top->clk = 1;
#if HG_SIM_GATE
            set_gates(g);
#endif
            trig[g] = Vl::learn_trigger(r, [&] {
                top->clk = 0;
#if HG_SIM_GATE
                set_gates(0);
#endif
            });
            if (__builtin_popcountll(trig[g]) != 1 + __builtin_popcount(g) ||
                (g && (trig[g] & trig[0]) != trig[0])) {
                std::fprintf(stderr, "error: the model's trigger vector for clocks %#x is %#llx\n", g,
                             static_cast<unsigned long long>(trig[g]));
                std::exit(3);
            }
        }
    }

    // One rising edge (eval_edge, tb/native/vl_internals.h): the input-combinational phase if an input changed,
    // then the NBA phase of the clocks that rise.
    void eval_edge(unsigned g) {
        Vl::eval_edge(top->rootp, trig[g], inputs_changed);
        inputs_changed = false;
    }
#if HG_SOC
    using Vl = HG_VL_PHASES(Vhapgate_soc_top);
#else
    using Vl = HG_VL_PHASES(Vhapgate_top);
#endif
#endif

#if HG_SIM_GATE
    // the stage clocks (README "Stage clocks"): the interpolators' four, the commutator's
    // datapath, the bus; each ticks with clk in the cycles whose enable the design announced
    // after the previous edge, the bus clock also in the cycle after the HAL changed a pin
    uint8_t gates = hg_dev::kAllGates;
    bool pins_changed = false;
    void set_gates(unsigned g) { hg_dev::set_gates(*top, g); }
#endif
    // the stage clocks as TestB's edge functions drive them (testb.h): those of gate bits g
    // with clk's rising edge, all low with its falling edge
    auto clocks(unsigned g) {
        return [this, g](bool high) {
#if HG_SIM_GATE
            set_gates(high ? g : 0);
#else
            (void)this, (void)g, (void)high;
#endif
        };
    }
    void pins() {   // the HAL changed a bus pin: the bus clock ticks at the next edge
        inputs_changed = true;
#if HG_SIM_GATE
        pins_changed = true;
#endif
    }

    __attribute__((always_inline)) void tick() {
        // the ports read after the edge, from the model's own variables (the wrapper's members
        // are references to them: one load fewer each)
        const Root* out = top->rootp;
#if HG_SIM_GATE
        const unsigned g = pins_changed ? (gates | hg_dev::kBusGate) : gates;
        pins_changed = false;
#else
        const unsigned g = 0;
#endif
#if HG_FI
        if (__builtin_expect(edge + 1 == fi.on_edge(), 0) && fi.before(*top, edge + 1)) inputs_changed = true;
#endif
#if HG_TRACE
        rise(clocks(g));   // (the public eval(): it also marks the trace's activity)
#else
        eval_edge(g);
        ++edge;
#endif
#if HG_FI
        if (__builtin_expect(edge == fi.off_edge(), 0) && fi.after(*top, edge)) {
#if HG_TRACE
            top->eval();
#else
            Vl::eval_edge(top->rootp, 0, true);   // the input logic again, no clock: the outputs
#endif                                             // read below are the design's
        }
#endif
#if HG_SIM_GATE
        gates = static_cast<uint8_t>(hg_dev::announced(*out) | (out->rst ? hg_dev::kAllGates : 0U));
#endif
        const int wr_n = out->dac_wr_n;
        if (wr_n && !prev_wr_n) {
            const int code = hg_dac::decode(out->dac_data);
            const int ch = static_cast<int>(out->dac_addr);
            if (cfg->record & 2) loads.push({static_cast<int64_t>(edge), ch, code});
            if (view) view_link_load(view, static_cast<double>(edge) / CLK_HZ - static_cast<double>(scene0_us) * 1e-6, ch, code);
            // frame n of this load: edge = n*FRAME + ch*SKEW + LOAD
            const uint64_t st = edge - kLoadClocks - static_cast<uint64_t>(ch) * skew;
            const uint64_t n = frame ? st / frame : 0;
            pend.push_back({n * (frame / D) + static_cast<uint64_t>(ch) * (skew / D) + kDacDelayUs, ch, code});
            frame_codes[ch] = static_cast<int16_t>(code);
            if (ch == 5 && !frames.empty() && (cfg->record & 2))
                std::memcpy(frames.back().dac, frame_codes, sizeof frame_codes);
        }
        prev_wr_n = wr_n;
#if HG_SOC
        const int irq = out->hapgate_soc_top->irq;
        soc_edge(out);
#else
        const int irq = out->irq;
#endif
        if (irq && !prev_irq) {
            irq_rose = true;
            irq_edge = edge;
        }
        prev_irq = irq;
#if HG_TRACE
        fall(clocks(0));
#endif
        // (Without a trace the falling edge is not evaluated: nothing in the design works on it,
        // the inputs set now are read by the next rising edge's evaluation, and eval_edge never
        // reads the clock inputs.)
        if (edge % D == 0) grid(edge / D);
    }
};

Bench* B = nullptr;
hg_dev::Scenario SC;   // the scene's faults, ISR records, enable (harness_common.h)

}  // namespace

#if !HG_SOC
// ------------------------------------------------------------------ the HAL: one access per 2 us
// The shared bus master (bus_hal.h) on the grid: CE and address at a grid point g, strobe from
// g + 1 clock to the next grid point (D - 1 >= 5 clocks), hold 2 clocks; the next access starts
// at the grid point after. Read data are taken just before the strobe rises.
struct BusTimer {
    double t0 = 0;
    BusTimer() { if (g_profile && g_in_isr) t0 = now_s(); }
    ~BusTimer() { if (g_profile && g_in_isr) g_bus_in_isr_s += now_s() - t0; }
};
constexpr hg_bus::Timing kBus = hg_bus::device_timing(D);

extern "C" uint32_t fpga_read32(uint32_t addr) {
    BusTimer bt;
    return hg_bus::read(*B, kBus, addr);
}

extern "C" void fpga_write32(uint32_t addr, uint32_t v) {
    if (SC.write_lost(addr)) return;  // injected fault: the key write is lost
    BusTimer bt;
    uint64_t rise = 0;
    hg_bus::write(*B, kBus, addr, v, nullptr, &rise);
    if (addr == HG_REG_WDOG) SC.key_written(static_cast<int64_t>(rise));
}

extern "C" uint32_t hg_hal_irq_save(void) { return 0; }

namespace {
// One telemetry line of the live view (view_link.h): the sample taken at the last frame start,
// with the firmware's state now; again: the same sample once more (while paused).
void view_send(ViewLink* v, const hg_servo_t& s, const ViewCtl& ctl, const UartLink* link, bool again = false) {
    ViewFw fw{};
    fw.err = s.err;
    fw.err_axis = s.err_axis;
    fw.enabled = s.enabled;
    fw.drive = s.enabled && s.err == HG_ERR_NONE;
    fw.status = s.status;
    for (int i = 0; i < 3; ++i) {
        fw.f[i] = s.f[i];
        fw.tau[i] = s.tau[i];
    }
    uint32_t counters[4];
    fw.pc_age_s = NAN;
    if (link && !uart_link_scripted(link)) {
        uart_link_counters(link, counters);
        fw.link = counters;
        fw.pc_age_s = static_cast<double>(s.f_pc_age) / s.cfg.rate_hz;
    } else if (link) {
        uart_link_counters(link, counters);
        fw.link = counters;
    }
    if (again) view_link_again(v);
    view_link_send(v, fw, ctl);
}
}  // namespace
extern "C" void hg_hal_irq_restore(uint32_t token) { (void)token; }
#endif  // !HG_SOC

// The hand during bring-up: as configured until the first step starts; from then on off (the
// operator lets go for bring-up), except on the scripted move while a GUIDED step runs (scene
// hand.guided: a spring from the endpoint at the step's start along the displacements; none:
// the move never comes; the hand finishes the move and holds its end kGuidedHoldS even when the
// step has already seen it), until the forces are enabled (the operator takes the handle back).
// A rigid grip (hand kind fixed) never lets go: the held handle. Called after each ISR.
constexpr double kGuidedHoldS = 0.2;   // s the hand holds the end of the guided move

static void guided_hand(hg_plant* plant, const hg_dev::RunCfg& cfg, bool bu_active, int bu_step,
                        bool enabled) {
    static int mode = -2;   // -1 configured hand, 0 off, 1 guided
    static bool session = false;
    static double guided_until = -1.0;   // plant time the scripted move ends (the hand lets go)
    if (bu_active) session = true;
    if (enabled) session = false;
    hg_plant_out o;
    hg_plant_read(plant, &o);
    const bool guided = (bu_active && bu_step == HG_BU_STEP_GUIDED && !cfg.guided.empty())
                     || (mode == 1 && o.t < guided_until);   // the operator finishes the move
    const int want = guided ? 1 : session ? 0 : -1;
    if (want == mode) return;
    mode = want;
    if (want != 1) {
        hg_plant_set_hand(plant, want, nullptr, 0);
        return;
    }
    guided_until = o.t + cfg.guided[cfg.guided.size() - 4] + kGuidedHoldS;
    std::vector<double> path(cfg.guided);
    for (size_t k = 0; k + 3 < path.size(); k += 4) {
        path[k] += o.t;
        for (int i = 0; i < 3; ++i) path[k + 1 + i] += o.p[i];
    }
    hg_plant_set_hand(plant, 1, path.data(), static_cast<int>(path.size() / 4));
}

#if HG_SOC
// ------------------------------------------------------------------ soc fidelity
namespace {
// The firmware's tick observation in the CPU's RAM (dsp-fw/board/riscv/soc.h soc_tick_obs_t)
struct SocObs {
    uint32_t count;
    float q[3], p[3], f[3], tau[3];
    int32_t pos[3];
    uint32_t status, err, bringup;
};
static_assert(sizeof(SocObs) == 19 * 4, "soc_tick_obs_t: 19 words");

struct SocRam {
    const Root* root;
    uint32_t word(uint32_t addr) const {
        return root->hapgate_soc_top->u_soc->u_ram__DOT__mem[addr / 4];
    }
    template <class T>
    void read(uint32_t addr, T* out) const {
        uint32_t w[sizeof(T) / 4];
        for (size_t i = 0; i < sizeof(T) / 4; ++i) w[i] = word(addr + 4 * static_cast<uint32_t>(i));
        std::memcpy(out, w, sizeof(T));
    }
};

void link_counters(void* ctx, uint32_t out[4]) {
    const auto* r = static_cast<const std::pair<SocRam, uint32_t>*>(ctx);
    hg_link_stats_t st;
    r->first.read(r->second, &st);
    out[0] = st.good;
    out[1] = st.bad_framing + st.bad_crc + st.bad_version + st.bad_type + st.bad_len;
    out[2] = st.replayed;
    out[3] = st.timeouts;
}
}  // namespace

// The closed loop with the SoC: the same clock loop (Bench::tick: the DAC monitor, the grid,
// the plant), the scene's fixture and faults (hg_dev::Scenario), the records; everything the
// firmware does, it does on the CPU from the image's stored setup (hapgate.device.soc). Per
// grid point: the release at scene time 0, the faults, a tick record whenever the firmware's
// observation count advanced (the tick it belongs to: the last rise of the interrupt), the
// operator's hand during bring-up, the PC link.
static int run_soc(Bench& bench, const RunCfg& cfg, hg_plant* plant, const char* link_cfg,
                   const char* run_cfg, const std::string& outdir,
                   std::chrono::steady_clock::time_point w0, std::clock_t c0) {
    auto& top = *bench.top;
    if (!cfg.soc_obs_seen) {
        std::fprintf(stderr, "error: %s: soc_obs = OBS LINK ISR_MAX (the firmware's RAM addresses) is required\n", run_cfg);
        return 2;
    }
    if (cfg.view_fd >= 0) {
        std::fprintf(stderr, "error: %s: view_fd: the live view needs the rtl fidelity\n", run_cfg);
        return 2;
    }
    for (const auto& f : cfg.faults)
        if (f.kind != hg_dev::FaultKind::dropout && f.kind != hg_dev::FaultKind::hang) {
            std::fprintf(stderr, "error: %s: fault %s is not simulated at the soc fidelity\n", run_cfg, hg_dev::fault_name(f.kind));
            return 2;
        }
    const SocRam ram{top.rootp};
    const std::pair<SocRam, uint32_t> link_ram{ram, cfg.soc_obs[1]};
    UartLink* link = link_cfg ? uart_link_open(link_cfg, nullptr, cfg.servo_hz) : nullptr;
    hg_uart::UartPins pins;
    if (link) {
        uart_link_attach_pins(link, &pins, CLK_HZ, link_counters, const_cast<std::pair<SocRam, uint32_t>*>(&link_ram));
        bench.uart_pins = &pins;
    }
    bench.scene0_us = static_cast<int64_t>(std::llround(cfg.t_hold_s * 1e6));
    const uint64_t end_us = static_cast<uint64_t>(bench.scene0_us) + static_cast<uint64_t>(std::llround(cfg.duration_s * 1e6));
    const bool scripted = link && uart_link_scripted(link);
    if (scripted) uart_link_set_origin(link, static_cast<uint64_t>(bench.scene0_us));
    SC.start(cfg, bench.scene0_us, D);
    auto* cpu = top.rootp->hapgate_soc_top->u_soc->u_cpu;
    const uint32_t obs_addr = cfg.soc_obs[0];
    uint32_t obs_count = 0;
    bool ticking = false;          // the interrupt has risen once: the RAM holds the firmware's
    uint64_t tick_g = 0;
    SocObs obs{};
    hg_servo_t s{};                // the observed state, as the native harness records it

    while (bench.edge < end_us * D) {
        bench.tick();
        if (bench.edge % D != 0) continue;
        const uint64_t g_now = bench.edge / D;
        if (!bench.dynamic && static_cast<int64_t>(g_now) >= bench.scene0_us) {
            hg_plant_hold(plant, 0);
            hg_plant_set_q(plant, cfg.q0, cfg.qd0);
            bench.dynamic = true;
        }
        SC.at_grid(static_cast<int64_t>(g_now), [&](const RunCfg::Fault& f) {
            if (f.kind == hg_dev::FaultKind::dropout) bench.dropout[f.axis] = true;
            // the CPU stops taking interrupts: an upset clears mstatus.MIE (nothing sets it again)
            if (f.kind == hg_dev::FaultKind::hang) cpu->CsrPlugin_mstatus_MIE = 0;
        });
        if (bench.irq_rose) {
            bench.irq_rose = false;
            tick_g = bench.irq_edge / D;
            if (!ticking) obs_count = ram.word(obs_addr);
            ticking = true;
        }
        if (ticking && ram.word(obs_addr) != obs_count) {
            ram.read(obs_addr, &obs);
            obs_count = obs.count;
            for (int i = 0; i < 3; ++i) {
                s.q[i] = obs.q[i];
                s.p[i] = obs.p[i];
                s.f[i] = obs.f[i];
                s.tau[i] = obs.tau[i];
                s.pos[i] = obs.pos[i];
            }
            s.status = obs.status;
            s.err = static_cast<uint8_t>(obs.err & 0xFFu);
            s.err_axis = static_cast<uint8_t>((obs.err >> 8) & 0xFFu);
            s.enabled = (obs.err >> 16) & 1u;
            const uint64_t gs = tick_g - 1;   // the snapshot holds the sample before the tick
            SC.ticks.push_back(hg_dev::tick_record(s, bench.scene_t(tick_g), &bench.qtrue_ring[(gs % Bench::kRing) * 3]));
            if (link && !scripted && SC.ticks.size() >= 65536) SC.ticks.clear();  // serving: runs until a signal
            if (s.enabled && !SC.is_enabled()) SC.enabled(bench.scene_t(tick_g));
            guided_hand(plant, cfg, obs.bringup & 1u, static_cast<int>(obs.bringup >> 8), s.enabled);
        }
        if (link) uart_link_service(link, g_now);
    }
    const double wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - w0).count();
    const double cpu_s = static_cast<double>(std::clock() - c0) / CLOCKS_PER_SEC;
    bench.frames.close();
    SC.finish(outdir);
    bench.loads.close();
    bench.adc.close();
    const uint32_t wdog_us = top.rootp->hapgate_soc_top->u_top__DOT__u_bus__DOT__u_regs__DOT__wd_timeout_q;
    const double sim_s = static_cast<double>(end_us - static_cast<uint64_t>(bench.scene0_us)) * 1e-6;
    hg_dev::print_summary({CLK_HZ, AXIS_MASK, sim_s, wall_s, cpu_s, bench.edge, bench.frames.size(), SC.ticks.size(),
                           bench.loads.size(), 0, s.err, s.err_axis, SC.enable_t(), wdog_us,
                           static_cast<uint64_t>(bench.key_edge), bench.scene0_us, bench.skew, bench.frame, D});
    std::printf("soc_isr_cycles_max=%u soc_isr_count=%u\n", ram.word(cfg.soc_obs[2]), obs_count);
    if (link) uart_link_summary(link, stdout);
    hg_plant_free(plant);
    return 0;
}
#endif  // HG_SOC

int main(int argc, char** argv) {
    if (argc != 4 && argc != 5) {
        std::fprintf(stderr, "usage: %s PLANT_CFG RUN_CFG OUTDIR [LINK_CFG]\n", argv[0]);
        return 2;
    }
    RunCfg cfg;
    std::string err;
    const std::string ptext = hg_dev::slurp(argv[1]);
    if (!hg_dev::parse_run(hg_dev::slurp(argv[2]), cfg, err, false)) {
        std::fprintf(stderr, "error: %s: %s\n", argv[2], err.c_str());
        return 2;
    }
    char perr[256] = {0};
    hg_plant* plant = hg_plant_new(ptext.c_str(), perr, sizeof perr);
    if (!plant) {
        std::fprintf(stderr, "error: %s: %s\n", argv[1], perr);
        return 2;
    }
    const std::string outdir = argv[3];
    g_profile = std::getenv("HG_PROFILE") && std::getenv("HG_PROFILE")[0] == '1';
    Bench bench;
    B = &bench;
    bench.plant = plant;
    bench.cfg = &cfg;
    bench.qtrue_ring.assign(Bench::kRing * 3, 0.0);
    bench.frames.open(outdir + "/frames.bin");
    bench.loads.open(outdir + "/loads.bin");
    bench.adc.open(outdir + "/adc.bin");
    // integrator steps per grid point (dt from the plant config: 1e-6 / dt)
    {
        double dt = 1e-6;
        std::istringstream in(ptext);
        std::string line;
        while (std::getline(in, line))
            if (line.rfind("dt_s", 0) == 0) dt = std::strtod(line.substr(line.find('=') + 1).c_str(), nullptr);
        bench.steps_per_us = std::max(1, static_cast<int>(std::lround(1e-6 / dt)));
    }
    auto& top = *bench.top;
#if HG_TRACE
    bench.trace(outdir + "/trace.vcd");
#endif
#if AXIS_MASK != 7
    hg_dev::set_held(top, cfg.hold_pos_homed, cfg.hold_index_pos, cfg.hold_index_count);
#endif
#if HG_SOC
    top.uart_rx = 1;                                 // the line idles high
#else
    top.bus_ce_n = top.bus_re_n = top.bus_we_n = 1;
#endif
    top.eval();                                      // the initial blocks, clk low, rst high
    bench.hold_reset(4, bench.clocks(hg_dev::kAllGates));
    bench.release();
#if !HG_TRACE
    bench.learn_triggers();
#endif
    bench.prev_wr_n = top.dac_wr_n;
#if HG_SOC
    bench.frame = HG_DAC_FRAME;
    bench.skew = HG_DAC_SKEW;
#endif
    hg_plant_hold(plant, 1);
    bench.grid(0);

    const auto w0 = std::chrono::steady_clock::now();
    const std::clock_t c0 = std::clock();
#if HG_SOC
    return run_soc(bench, cfg, plant, argc == 5 ? argv[4] : nullptr, argv[2], outdir, w0, c0);
#else
    // ---------------------------------------------------------------- firmware bring-up
    hg_servo_cfg_t fw;
    hg_dev::fw_config(cfg, CLK_HZ, &fw);
    hg_calib_t stored;        // the board's flash: the scene's calibration, if it has one
    const bool have_stored = hg_dev::fw_store_calib(&fw, &stored);
    static hg_servo_t s;
    static hg_bringup_t bu;   // reachable from the link once the power-up has recorded the pose
    const uint8_t init_err = hg_servo_init(&s, &fw);
    bench.skew = fpga_read32(HG_WORD(offsetof(hapgate_t, DAC_SKEW)));
    bench.frame = fpga_read32(HG_WORD(offsetof(hapgate_t, DAC_FRAME)));
    const uint32_t wdog_us = fpga_read32(HG_REG_WDOG_TIMEOUT);
    hg_servo_isr_ctx = &s;
    UartLink* link = argc == 5 ? uart_link_open(argv[4], &s, cfg.servo_hz) : nullptr;
    if (init_err != HG_ERR_NONE) std::fprintf(stderr, "warning: firmware init error %u\n", init_err);
    const bool served = link && !uart_link_scripted(link);     // a PC on the pty: never paused
    ViewCtl vctl;
    if (cfg.view_fd >= 0)
        bench.view = view_link_open(cfg.view_fd, cfg.ctl_fd, cfg.view_period_s,
                                    static_cast<double>(bench.frame) / CLK_HZ * 1e6, outdir, !served);

    // scene time 0: the fixture that held the handle in the start pose since reset lets go
    bench.scene0_us = static_cast<int64_t>(std::llround(cfg.t_hold_s * 1e6));
    const uint64_t end_us = static_cast<uint64_t>(bench.scene0_us) + static_cast<uint64_t>(std::llround(cfg.duration_s * 1e6));
    const bool scripted = link && uart_link_scripted(link);   // a scene's scripted PC
    if (scripted) uart_link_set_origin(link, static_cast<uint64_t>(bench.scene0_us));
    SC.start(cfg, bench.scene0_us, D);
#if HG_FI
    {
        std::string ferr;
        if (bench.fi.start(cfg, bench.scene0_us, D, CLK_HZ, bench.frame, ferr) < 0) {
            std::fprintf(stderr, "error: %s: %s\n", argv[2], ferr.c_str());
            return 2;
        }
    }
#else
    for (const auto& f : cfg.faults)
        if (hg_dev::is_injection(f.kind)) {
            std::fprintf(stderr, "error: %s: fault %s needs the saboteur build (HG_FI)\n", argv[2], hg_dev::fault_name(f.kind));
            return 2;
        }
#endif
    bool hang = false;   // (SC.hanging(), kept here for the clock loop's test)

    while (bench.edge < end_us * D) {
        bench.tick();
        // Between grid points only an interrupt (or, while the DSP hangs, its resumption at an
        // edge of its own) has anything to do below: the release, the progress line, the faults
        // and the link all wait for the grid point (g_now changes only there).
        if (bench.edge % D != 0 && !bench.irq_rose && !hang) continue;
        const uint64_t g_now = bench.edge / D;
        if (!bench.dynamic && static_cast<int64_t>(g_now) >= bench.scene0_us) {
            hg_plant_hold(plant, 0);
            hg_plant_set_q(plant, cfg.q0, cfg.qd0);
            bench.dynamic = true;
        }
        SC.at_grid(static_cast<int64_t>(g_now), [&](const RunCfg::Fault& f) {
            const bool drop = f.kind == hg_dev::FaultKind::dropout;
            if (drop) bench.dropout[f.axis] = true;
            if (bench.view) {   // the cause as runner.events times it
                const double cause = drop ? f.at_s + 16e-6
                    : static_cast<double>(SC.last_key_edge()) / CLK_HZ - static_cast<double>(bench.scene0_us) * 1e-6 + wdog_us * 1e-6;
                view_link_fault(bench.view, hg_dev::fault_name(f.kind), drop ? f.axis : -1, cause, drop ? 1 << f.axis : 7);
            }
        });
        hang = SC.hanging();
        if (bench.view && view_link_ready(bench.view)) {
            view_send(bench.view, s, vctl, link);
            view_link_poll(bench.view, vctl, 0);
            while (vctl.paused) {          // simulated time stands; the page still hears from us
                view_link_poll(bench.view, vctl, 0.1);
                view_send(bench.view, s, vctl, link, true);
            }
            if (vctl.target_set) {
                hg_plant_set_target(plant, vctl.target);
                vctl.target_set = false;
            }
            if (vctl.forces_off) hg_servo_enable(&s, false);   // the firmware's disable: zero torque
        }
        const bool rose = bench.irq_rose;
        bench.irq_rose = false;
        if (!SC.isr_due(rose, static_cast<int64_t>(bench.edge), top.irq != 0, wdog_us)) {
            if (link && bench.edge % D == 0) uart_link_service(link, g_now);  // background loop, from reset
            continue;
        }
        const uint64_t tick_g = (rose ? bench.irq_edge : bench.edge) / D;
        double ti0 = 0;
        if (g_profile) {
            ti0 = now_s();
            g_in_isr = true;
        }
        if (vctl.forces_off && s.enabled) hg_servo_enable(&s, false);   // a PC may not re-enable
        if (vctl.forces_off && hg_bringup_active(&bu)) hg_bringup_abort(&bu, HG_BU_ERR_ABORT);
        hg_bringup_isr();   // the bring-up step while one runs, else the servo step
        if (g_profile) {
            g_isr_s += now_s() - ti0;
            g_in_isr = false;
        }
        // the snapshot holds the sample of grid point tick_g - 1 (the one visible at the tick)
        const uint64_t gs = tick_g - 1;
        guided_hand(plant, cfg, hg_bringup_active(&bu), bu.step, s.enabled);
        if (link && !scripted && SC.ticks.size() >= 65536) SC.ticks.clear();  // serving: runs until a signal
        // ---- background loop (board.c's main): the power-up once the snapshot has settled, then
        // the scene's start at the tick before scene time 0 (its enable, unless a PC enables)
        switch (SC.after_isr(s, static_cast<int64_t>(tick_g), &bench.qtrue_ring[(gs % Bench::kRing) * 3])) {
        case hg_dev::Scenario::Bg::power_up: {
            const int rc = hg_dev::fw_power_up(&s, &bu, cfg, have_stored ? &stored : nullptr);
            if (rc != 0) return rc;
            hg_bringup_isr_ctx = &bu;
            if (link) uart_link_set_bringup(link, &bu);
            break;
        }
        case hg_dev::Scenario::Bg::scene:
            if (!link && !vctl.forces_off && hg_servo_calibrated(&s) && hg_servo_enable(&s, true) != 0) {
                std::fprintf(stderr, "error: the firmware refused to enable\n");
                return 3;
            }
            SC.enabled(bench.scene_t(bench.edge / D));
            break;
        case hg_dev::Scenario::Bg::none:
            break;
        }
    }
    const double wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - w0).count();
    const double cpu_s = static_cast<double>(std::clock() - c0) / CLOCKS_PER_SEC;  // one core
    // ---------------------------------------------------------------- outputs
    bench.frames.close();
    SC.finish(outdir);
    bench.loads.close();
    bench.adc.close();
    const double sim_s = static_cast<double>(end_us - static_cast<uint64_t>(bench.scene0_us)) * 1e-6;
    hg_dev::print_summary({CLK_HZ, AXIS_MASK, sim_s, wall_s, cpu_s, bench.edge, bench.frames.size(), SC.ticks.size(),
                           bench.loads.size(), init_err, s.err, s.err_axis, SC.enable_t(), wdog_us,
                           static_cast<uint64_t>(SC.last_key_edge()),
                           bench.scene0_us, bench.skew, bench.frame, D});
    if (link) uart_link_summary(link, stdout);
#if HG_FI
    bench.fi.summary(stdout);
#endif
    if (g_profile)
        std::printf("profile_plant_s=%.6g profile_firmware_s=%.6g profile_gateware_s=%.6g\n", g_plant_s,
                    g_isr_s - g_bus_in_isr_s, wall_s - g_plant_s - (g_isr_s - g_bus_in_isr_s));
    hg_plant_free(plant);
    return 0;   // (~TestB: the model's final(), the trace closed)
#endif  // !HG_SOC
}
