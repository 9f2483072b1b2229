// SPDX-License-Identifier: Apache-2.0
// The record layouts as the C++ compiler lays them out: one line per field,
// "<record> <field> <offset> <size> <kind><item size>", and "<record> . 0 <sizeof> -". tb/device/test_record_layout.py
// builds this against harness_common.h and compares every line with the numpy dtypes of
// hapgate.device.harness (FRAME_DT, TICK_DT, LOAD_DT): the layout is written in two languages,
// and this is the check that they agree. Then the fault kinds, "FaultKind <name> <value> <found by name> -" in
// the order of kFaultKinds, checked against hapgate.device.harness.HARNESS_FAULTS.
#include <cstddef>
#include <cstdio>

#include "harness_common.h"

#include <type_traits>

// the element type's numpy kind: f (floating), i (signed integer), u (unsigned integer)
template <typename T>
constexpr char kind() {
    using E = std::remove_all_extents_t<T>;
    return std::is_floating_point_v<E> ? 'f' : std::is_signed_v<E> ? 'i' : 'u';
}
#define FIELD(rec, f)                                                                   \
    std::printf("%s %s %zu %zu %c%zu\n", #rec, #f, offsetof(hg_dev::rec, f),             \
                sizeof(hg_dev::rec::f), kind<decltype(hg_dev::rec::f)>(),                \
                sizeof(std::remove_all_extents_t<decltype(hg_dev::rec::f)>))
#define TOTAL(rec) std::printf("%s . 0 %zu -\n", #rec, sizeof(hg_dev::rec))

int main() {
    FIELD(FrameRec, t); FIELD(FrameRec, q); FIELD(FrameRec, p); FIELD(FrameRec, f_hand);
    FIELD(FrameRec, tau); FIELD(FrameRec, i_ab); FIELD(FrameRec, energy); FIELD(FrameRec, dac);
    FIELD(FrameRec, pad); FIELD(FrameRec, pad2); TOTAL(FrameRec);
    FIELD(TickRec, t); FIELD(TickRec, q_fw); FIELD(TickRec, q_true); FIELD(TickRec, p_fw);
    FIELD(TickRec, f_fw); FIELD(TickRec, tau_fw); FIELD(TickRec, pos_err); FIELD(TickRec, pos);
    FIELD(TickRec, status); FIELD(TickRec, err); FIELD(TickRec, err_axis); FIELD(TickRec, drive);
    FIELD(TickRec, pad); TOTAL(TickRec);
    FIELD(LoadRec, edge); FIELD(LoadRec, ch); FIELD(LoadRec, code); TOTAL(LoadRec);
    for (const auto& f : hg_dev::kFaultKinds) {
        hg_dev::FaultKind k{};
        const bool found = hg_dev::fault_kind_of(f.name, &k) && k == f.kind;
        std::printf("FaultKind %s %d %d -\n", f.name, static_cast<int>(f.kind), found);
    }
    return 0;
}
