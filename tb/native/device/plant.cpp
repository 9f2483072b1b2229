// SPDX-License-Identifier: Apache-2.0
// The plant of the virtual device (see plant.h and README.md): motors + amplifiers, linkage
// dynamics with a hand, encoder front end. Double precision throughout, no allocation in the
// step, no dependence on the firmware (the firmware is what it tests).
#include "dac_word.h"
#include "plant.h"

#include <cmath>
#include <cstdio>
#include <cstring>
#include <map>
#include <utility>
#include <sstream>
#include <string>
#include <vector>

namespace {

constexpr double kPi = 3.14159265358979323846;

struct Params {
    double dt = 1e-6;                 // s, integrator step
    double kt = 0.06;                 // N m / A (amplitude of the sinusoidal phase current)
    double r_ohm = 1.2;               // winding resistance (for the dissipation read-out only)
    double j_rotor = 1.6e-5;          // kg m^2 per motor
    int pole_pairs = 2;
    double i_max = 8.0;               // A, amplifier limit
    double bw_hz = 2000.0;            // current-loop bandwidth (first-order lag)
    double i_fs = 8.0;                // A at DAC code dac_fs (10 V x 0.8 A/V)
    double dac_fs = hg_dac::kFullScale;   // (dac_word.h)
    double arm = 0.05;                // m, L_beta = L_gamma (docs/design/KINEMATICS.md)
    double m_link = 0.02, m_handle = 0.01;  // kg, lumped at the endpoint
    double b_visc[3] = {2e-4, 2e-4, 2e-4};  // N m s / rad
    double tau_c[3] = {0, 0, 0};            // N m, Coulomb
    double coulomb_w = 1e-3;                // rad/s, width of the regularised sign
    // Link compliance (README "Link compliance"): one structural mode per joint, the rotor
    // (motor and encoder side) coupled to the linkage by a spring and a damper; 0: rigid
    double k_link[3] = {0, 0, 0};           // N m / rad
    double b_link[3] = {0, 0, 0};           // N m s / rad
    bool gravity = false;
    double gk[12] = {0};
    double q_ab = 0, q_ac = 0;
    int hand = 0;                     // 0 none, 1 spring, 2 fixed
    double hand_k = 500.0, hand_b = 2.0;
    std::vector<double> path;         // t, x, y, z per point
    double amp[3] = {110, 110, 110}, off_a[3] = {0, 0, 0}, off_b[3] = {0, 0, 0};
    double gain_a[3] = {1, 1, 1}, gain_b[3] = {1, 1, 1}, phase[3] = {0, 0, 0};  // phase in rad
    double h2[3] = {0, 0, 0}, h3[3] = {0, 0, 0}, noise[3] = {0, 0, 0};
    double q_index[3] = {0, 0, 0};    // rad: joint angle of the index
    double comm_off[3] = {0, 0, 0};   // rad electrical: winding zero's angle after the index
    bool swapped[3] = {false, false, false};   // amplifier inputs a and b swapped (wiring fault)
    bool enc_swap[3] = {false, false, false};  // encoder A and B swapped: counts run backwards
    double q0[3] = {0, 0, 0};
    double t0 = 0.0;                  // s, plant time at start
    bool free_[3] = {true, true, true};
    uint64_t seed = 1;
    double lines = 1024.0;
};

struct Rng {  // xoshiro256+ seeded by splitmix64
    uint64_t s[4];
    explicit Rng(uint64_t seed = 1) {
        uint64_t x = seed;
        for (auto& v : s) {
            x += 0x9E3779B97F4A7C15ULL;
            uint64_t z = x;
            z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ULL;
            z = (z ^ (z >> 27)) * 0x94D049BB133111EBULL;
            v = z ^ (z >> 31);
        }
    }
    static uint64_t rotl(uint64_t x, int k) { return (x << k) | (x >> (64 - k)); }
    double uniform() {  // (0, 1]
        const uint64_t r = s[0] + s[3];
        const uint64_t t = s[1] << 17;
        s[2] ^= s[0]; s[3] ^= s[1]; s[1] ^= s[2]; s[0] ^= s[3];
        s[2] ^= t;
        s[3] = rotl(s[3], 45);
        return (static_cast<double>(r >> 11) + 1.0) * (1.0 / 9007199254740992.0);
    }
    double normal() {  // Box-Muller, one of the pair
        return std::sqrt(-2.0 * std::log(uniform())) * std::cos(2 * kPi * uniform());
    }
};

}  // namespace

struct hg_plant {
    Params P;
    int hand0 = 0;                    // the configured hand (hg_plant_set_hand(-1) restores it)
    std::vector<double> path0;
    Rng rng;
    double t = 0;
    double q[3], qd[3];               // the linkage's joint angles and rates
    double qm[3], qdm[3];             // the rotors' (the encoders'): q, qd when rigid
    bool compliant = false;           // any link compliance (link_k_nm_per_rad not all 0)
    double ia[3] = {0, 0, 0}, ib[3] = {0, 0, 0};
    double icmd_a[3] = {0, 0, 0}, icmd_b[3] = {0, 0, 0};
    double alpha = 0;                 // current-loop step factor
    double alpha_us = 0;              // the same for 1 us (hg_plant_amp_us)
    double decay[65] = {0};           // (1 - alpha_us)^n, n = 0..64
    double mean_decay[65] = {0};      // mean over j = 1..n of (1 - alpha_us)^j
    double Jprev[9];                  // the Jacobian of the last dynamic step (J-dot by difference)
    bool have_prev = false, held = false;
    double tau[3] = {0, 0, 0}, f_hand[3] = {0, 0, 0};
    // mech_step's joint trigonometry (joint_trig): sin, cos of tc_q, steps since exact
    double tc_s[3] = {0, 0, 0}, tc_c[3] = {1, 1, 1}, tc_q[3] = {0, 0, 0};
    int tc_age = 0;
    // The windings' torque factors in terms of sin, cos of pole_pairs * q (torque_pq): the
    // index offset's fixed rotation and kt * 2/3 * sqrt(3) folded in at construction
    double wa_s[3] = {0, 0, 0}, wa_c[3] = {0, 0, 0}, wb_s[3] = {0, 0, 0}, wb_c[3] = {0, 0, 0};
    // Products of parameters the 1 us step would otherwise form every step (hg_plant_new):
    double m_end = 0;                 // m_link + m_handle, the mass lumped at the endpoint
    bool all_free = true;             // no held joint: the mass matrix needs no masking
    bool coulomb = false;             // any Coulomb friction (tau_coulomb_nm not all 0)
    bool path_sorted = false;         // hand_path's times non-decreasing (target's search hint)
    mutable int path_seg = 0;         // the path segment of the last target() (a search hint only)
};

namespace {

// The joints' sines and cosines and the linkage's two radicals. ib, ig are the reciprocals:
// the Jacobian (L/d^3) and the forward kinematics (L/d) then need no division of their own,
// and each step needs two divisions instead of six.
struct Trig { double ca, sa, cb, sb, cg, sg, db, dg, ib, ig; };

inline Trig trig_sc(const double* sn, const double* cs) {   // from sin, cos of the joints
    Trig r;
    r.sa = sn[0]; r.ca = cs[0];
    r.sb = sn[1]; r.cb = cs[1];
    r.sg = sn[2]; r.cg = cs[2];
    r.db = std::sqrt(r.cb * r.cb + r.ca * r.ca * r.sb * r.sb);
    r.dg = std::sqrt(r.cg * r.cg + r.ca * r.ca * r.sg * r.sg);
    r.ib = 1 / r.db;
    r.ig = 1 / r.dg;
    return r;
}

inline Trig trig(const double* q) {
    double sn[3], cs[3];
    for (int i = 0; i < 3; ++i) sincos(q[i], &sn[i], &cs[i]);
    return trig_sc(sn, cs);
}

inline void fk_t(double L, const Trig& k, double* p) {
    const double lb = L * k.ib, lg = L * k.ig;   // L / db, L / dg
    const double rho = lb * k.cb + lg * k.cg;
    p[0] = -rho * k.sa;
    p[1] = rho * k.ca;
    p[2] = k.ca * (lg * k.sg - lb * k.sb);
}

// J = dp/dq (row-major), docs/design/KINEMATICS.md with h = 0. Column 1 depends on beta only through kb,
// column 2 on gamma only through kg: their common factors are formed once.
inline void jac_t(double L, const Trig& k, double* m) {
    const double ca = k.ca, sa = k.sa, cb = k.cb, sb = k.sb, cg = k.cg, sg = k.sg;
    const double kb = L * k.ib * k.ib * k.ib, kg = L * k.ig * k.ig * k.ig;   // L / d^3
    const double bc = kb * cb, gc = kg * cg, ca2 = ca * ca;
    const double bs = kb * ca2 * sb, gs = kg * ca2 * sg;
    m[0] = -ca * (bc + gc);
    m[3] = -sa * (bc * cb * cb + gc * cg * cg);
    m[6] = sa * (bc * cb * sb - gc * cg * sg);
    m[1] = bs * sa;
    m[4] = -bs * ca;
    m[7] = -bc * ca;
    m[2] = gs * sa;
    m[5] = -gs * ca;
    m[8] = gc * ca;
}

void fk(double L, const double* q, double* p) { fk_t(L, trig(q), p); }
void jac(double L, const double* q, double* m) { jac_t(L, trig(q), m); }

// dU/dq, the paper's equations (2)-(4) (independent of the firmware's copy), from the joints'
// sines and cosines (mech_step's, which it has anyway: six libm calls fewer per step).
void grad_u(const Params& P, const Trig& k, double* g) {
    const double sa = k.sa, ca = k.ca, sb = k.sb, cb = k.cb, sg = k.sg, cg = k.cg;
    const double db = std::sqrt(1 - sa * sa * sb * sb), dg = std::sqrt(1 - sa * sa * sg * sg);
    const double ib3 = 1 / (db * db * db), ig3 = 1 / (dg * dg * dg);
    const double cb2 = cb * cb, cg2 = cg * cg, ca3 = ca * ca * ca;
    const double* K = P.gk - 1;  // K[n] = k_n
    g[0] = -K[2] * sa + K[6] * ca - K[7] * cb2 * cb * sa * ib3 + K[8] * ca * cb2 * ib3 -
           K[9] * sa * ca * sb * (cb2 + P.q_ab * P.q_ab) * ib3 - K[10] * cg2 * cg * sa * ig3 +
           K[11] * ca * cg2 * ig3 - K[12] * sa * ca * sg * (cg2 + P.q_ac * P.q_ac) * ig3;
    g[1] = K[4] * cb - K[7] * sb * ca3 * ib3;
    g[2] = K[5] * cg - K[10] * sg * ca3 * ig3;
}

// Solve the n x n system (n <= 3, row-major in a 3x3 array) by Gaussian elimination with
// partial pivoting, in place. (The rigid grip's J^T system: not symmetric, may be ill-posed.)
void solve(double a[3][3], double* b, int n) {
    for (int c = 0; c < n; ++c) {
        int piv = c;
        for (int r = c + 1; r < n; ++r)
            if (std::fabs(a[r][c]) > std::fabs(a[piv][c])) piv = r;
        if (piv != c) {
            for (int k = 0; k < n; ++k) std::swap(a[c][k], a[piv][k]);
            std::swap(b[c], b[piv]);
        }
        for (int r = c + 1; r < n; ++r) {
            const double f = a[r][c] / a[c][c];
            for (int k = c; k < n; ++k) a[r][k] -= f * a[c][k];
            b[r] -= f * b[c];
        }
    }
    for (int c = n - 1; c >= 0; --c) {
        double s = b[c];
        for (int k = c + 1; k < n; ++k) s -= a[c][k] * b[k];
        b[c] = s / a[c][c];
    }
}

// Solve M x = b in place for the symmetric 3x3 mass matrix (its upper triangle m00..m22) by
// its adjugate: x = adj(M) b / det(M). The microsecond's steps form one chain of dependent
// operations (q -> J -> M -> qdd -> q), so the solve's latency counts: the six cofactors are
// independent and there is one division, where an elimination would chain three. M = J_r I +
// m J^T J is positive definite and well conditioned (its eigenvalues lie between J_r and
// J_r + m |J|^2, a ratio of ~10): the closed form is accurate to a few ulp times that. A held
// joint's row and column are the identity's and its b is 0 (mech_step): its x comes out 0 and
// the free joints get the reduced system's solution (the zeros enter only as exact products).
inline void solve_spd3(double m00, double m01, double m02, double m11, double m12, double m22,
                       double* b) {
    const double c00 = m11 * m22 - m12 * m12, c01 = m02 * m12 - m01 * m22, c02 = m01 * m12 - m02 * m11;
    const double c11 = m00 * m22 - m02 * m02, c12 = m01 * m02 - m00 * m12, c22 = m00 * m11 - m01 * m01;
    const double r = 1 / (m00 * c00 + m01 * c01 + m02 * c02);
    const double b0 = b[0], b1 = b[1], b2 = b[2];
    b[0] = (c00 * b0 + c01 * b1 + c02 * b2) * r;
    b[1] = (c01 * b0 + c11 * b1 + c12 * b2) * r;
    b[2] = (c02 * b0 + c12 * b1 + c22 * b2) * r;
}

// The hand's target at t on its path (t x y z per point): a smoothstep between points (C1, at
// rest at each). The segment is the first with t < its end time. With the path's times
// non-decreasing no segment before the cached one (path_seg, the last call's) qualifies as
// long as t is not before that segment's start: the search starts there and finds the same
// segment, instead of walking the path every microsecond. Values as from the full search.
void target(const hg_plant* s, double t, double* pt, double* vt) {
    const std::vector<double>& path = s->P.path;
    const int n = static_cast<int>(path.size() / 4);
    const double* w = path.data();
    if (n == 0 || t <= w[0] || n == 1) {
        for (int i = 0; i < 3; ++i) {
            pt[i] = n == 0 ? 0 : w[1 + i];
            vt[i] = 0;
        }
        return;
    }
    int k = (s->path_sorted && t >= w[4 * s->path_seg]) ? s->path_seg : 0;
    while (k + 1 < n && !(t < w[4 * k + 4])) ++k;
    s->path_seg = k;
    const double* a = w + 4 * k;   // this point; a + 4 the next
    if (k + 1 == n) {              // past the last point
        for (int i = 0; i < 3; ++i) {
            pt[i] = a[1 + i];
            vt[i] = 0;
        }
        return;
    }
    // smoothstep: C1, zero velocity at every point
    const double h = a[4] - a[0], u = (t - a[0]) / h;
    const double sm = u * u * (3 - 2 * u), ds = 6 * u * (1 - u) / h;
    const double d[3] = {a[5] - a[1], a[6] - a[2], a[7] - a[3]};
    const double p[3] = {a[1] + d[0] * sm, a[2] + d[1] * sm, a[3] + d[2] * sm};
    for (int i = 0; i < 3; ++i) {
        pt[i] = p[i];
        vt[i] = d[i] * ds;
    }
}

// Motor torques from the phase currents at the true electrical angles te = p (q - q_index) + c,
// p = pole_pairs, c = comm_offset_deg (winding 0's zero c after the index; 0 by default):
// tau = kt * 2/3 * (ia sin(te) + ib sin(te - 120) + ic sin(te - 240)), ic = -(ia + ib)
//     = kt * 2/3 * (ia (sin te - sin(te - 240)) + ib (sin(te - 120) - sin(te - 240)))
//     = kt * 2/3 * sqrt(3) * (ia cos(te - 120) - ib cos(te))   (sum to product)
// Both cosines are cos(p q - phi) = cos(p q) cos(phi) + sin(p q) sin(phi) with a fixed phi
// (p q_index - c + 120 and p q_index - c): from sp, cp = sin, cos(p q) they take two products
// each, the factors kt * 2/3 * sqrt(3) * (cos phi, sin phi) formed once (hg_plant_new,
// winding_factors). Swapped phases (winding 0 fed by channel b, winding 1 by a):
// tau = ib k cos(te - 120) - ia k cos(te) = ia (-k cos te) - ib (-k cos(te - 120)), the two
// factor pairs exchanged and negated, also once.
inline void torque_pq(const hg_plant* s, const double* ia, const double* ib, const double* sp,
                      const double* cp, double* tau) {
#pragma GCC unroll 3
    for (int m = 0; m < 3; ++m)
        tau[m] = ia[m] * (sp[m] * s->wa_s[m] + cp[m] * s->wa_c[m]) -
                 ib[m] * (sp[m] * s->wb_s[m] + cp[m] * s->wb_c[m]);
}

constexpr double kSqrt3 = 1.7320508075688772935;
void winding_factors(hg_plant* s) {
    const Params& P = s->P;
    const double k = P.kt * (2.0 / 3.0) * kSqrt3;
    for (int m = 0; m < 3; ++m) {
        const double phi = P.pole_pairs * P.q_index[m] - P.comm_off[m];
        double sn, cs;
        sincos(phi + 2 * kPi / 3, &sn, &cs);
        s->wa_s[m] = k * sn;
        s->wa_c[m] = k * cs;
        sincos(phi, &sn, &cs);
        s->wb_s[m] = k * sn;
        s->wb_c[m] = k * cs;
        if (P.swapped[m]) {
            std::swap(s->wa_s[m], s->wb_s[m]);
            std::swap(s->wa_c[m], s->wb_c[m]);
            s->wa_s[m] = -s->wa_s[m];
            s->wa_c[m] = -s->wa_c[m];
            s->wb_s[m] = -s->wb_s[m];
            s->wb_c[m] = -s->wb_c[m];
        }
    }
}

// The true electrical angles pole_pairs * (q - q_index) + c (read-outs; the step needs only
// the sines and cosines of pole_pairs * q).
inline void elec_angles(const hg_plant* s, double* th) {
    for (int m = 0; m < 3; ++m)
        th[m] = s->P.pole_pairs * (s->qm[m] - s->P.q_index[m]) + s->P.comm_off[m];
}

// The motor torques of the amplifier's present currents, their angles evaluated (read-out).
void motor_torque(const hg_plant* s, double* tau, double* th) {
    double sp[3], cp[3];
    elec_angles(s, th);
    for (int m = 0; m < 3; ++m) sincos(s->P.pole_pairs * s->qm[m], &sp[m], &cp[m]);
    torque_pq(s, s->ia, s->ib, sp, cp, tau);
}

bool parse(const char* text, Params& P, std::string& err) {
    std::map<std::string, std::vector<double>> kv;
    std::istringstream in(text);
    std::string line;
    int ln = 0;
    while (std::getline(in, line)) {
        ++ln;
        const auto hash = line.find('#');
        if (hash != std::string::npos) line.resize(hash);
        const auto eq = line.find('=');
        if (eq == std::string::npos) {
            if (line.find_first_not_of(" \t\r") != std::string::npos) {
                err = "line " + std::to_string(ln) + ": expected key = values";
                return false;
            }
            continue;
        }
        std::string key = line.substr(0, eq);
        key.erase(0, key.find_first_not_of(" \t"));
        key.erase(key.find_last_not_of(" \t") + 1);
        std::istringstream vs(line.substr(eq + 1));
        std::vector<double> v;
        std::string tok;
        while (vs >> tok) {
            char* end = nullptr;
            const double x = std::strtod(tok.c_str(), &end);
            if (!end || *end || !std::isfinite(x)) {
                err = "line " + std::to_string(ln) + ": " + key + ": bad number " + tok;
                return false;
            }
            v.push_back(x);
        }
        kv[key] = v;
    }
    auto take = [&](const char* k, double* dst, size_t n) -> bool {
        auto it = kv.find(k);
        if (it == kv.end()) return true;
        if (it->second.size() != n) {
            err = std::string(k) + ": expected " + std::to_string(n) + " values";
            return false;
        }
        for (size_t i = 0; i < n; ++i) dst[i] = it->second[i];
        kv.erase(it);
        return true;
    };
    double pp = P.pole_pairs, hand = P.hand, grav = 0, seed = static_cast<double>(P.seed);
    double fr[3] = {1, 1, 1}, ph_deg[3] = {0, 0, 0}, gq[2] = {0, 0};
    double co_deg[3] = {0, 0, 0}, sw[3] = {0, 0, 0}, edir[3] = {1, 1, 1};
    bool ok = take("dt_s", &P.dt, 1) && take("kt_nm_per_a", &P.kt, 1) && take("r_ohm", &P.r_ohm, 1) &&
              take("j_rotor_kg_m2", &P.j_rotor, 1) && take("pole_pairs", &pp, 1) &&
              take("i_max_a", &P.i_max, 1) && take("current_bw_hz", &P.bw_hz, 1) &&
              take("i_fs_a", &P.i_fs, 1) && take("dac_fs_code", &P.dac_fs, 1) &&
              take("arm_m", &P.arm, 1) && take("m_link_kg", &P.m_link, 1) &&
              take("m_handle_kg", &P.m_handle, 1) && take("b_visc_nms", P.b_visc, 3) &&
              take("tau_coulomb_nm", P.tau_c, 3) && take("gravity_on", &grav, 1) &&
              take("gravity_q", gq, 2) && take("hand_kind", &hand, 1) &&
              take("hand_k", &P.hand_k, 1) && take("hand_b", &P.hand_b, 1) &&
              take("enc_amplitude", P.amp, 3) && take("enc_offset_a", P.off_a, 3) &&
              take("enc_offset_b", P.off_b, 3) && take("enc_gain_a", P.gain_a, 3) &&
              take("enc_gain_b", P.gain_b, 3) && take("enc_phase_deg", ph_deg, 3) &&
              take("enc_h2", P.h2, 3) && take("enc_h3", P.h3, 3) &&
              take("enc_noise_lsb", P.noise, 3) && take("q_index", P.q_index, 3) &&
              take("q0", P.q0, 3) && take("t0_s", &P.t0, 1) && take("free", fr, 3) &&
              take("seed", &seed, 1) && take("lines", &P.lines, 1) &&
              take("comm_offset_deg", co_deg, 3) && take("phases_swapped", sw, 3) &&
              take("encoder_dir", edir, 3) && take("link_k_nm_per_rad", P.k_link, 3) &&
              take("link_b_nms_per_rad", P.b_link, 3);
    if (!ok) return false;
    if (kv.count("gravity_k")) {
        if (!take("gravity_k", P.gk, 12)) return false;
    }
    if (kv.count("hand_path")) {
        P.path = kv["hand_path"];
        kv.erase("hand_path");
        if (P.path.size() % 4 != 0) {
            err = "hand_path: expected groups of 4 values (t x y z)";
            return false;
        }
    }
    if (!kv.empty()) {
        err = "unknown key " + kv.begin()->first;
        return false;
    }
    P.pole_pairs = static_cast<int>(pp);
    P.hand = static_cast<int>(hand);
    P.gravity = grav != 0;
    P.q_ab = gq[0];
    P.q_ac = gq[1];
    P.seed = static_cast<uint64_t>(seed);
    for (int i = 0; i < 3; ++i) {
        P.free_[i] = fr[i] != 0;
        P.phase[i] = ph_deg[i] * kPi / 180.0;
        P.comm_off[i] = co_deg[i] * kPi / 180.0;
        if ((sw[i] != 0 && sw[i] != 1) || (edir[i] != 1 && edir[i] != -1)) {
            err = "phases_swapped must be 0 or 1 and encoder_dir +1 or -1";
            return false;
        }
        P.swapped[i] = sw[i] != 0;
        P.enc_swap[i] = edir[i] < 0;
    }
    for (int i = 0; i < 3; ++i)
        if (P.k_link[i] < 0 || P.b_link[i] < 0 || (P.k_link[i] == 0 && P.b_link[i] != 0)) {
            err = "link_k_nm_per_rad and link_b_nms_per_rad must be >= 0, and a damper needs "
                  "its spring";
            return false;
        }
    if (!(P.dt > 0) || P.pole_pairs < 1 || !(P.bw_hz > 0) || !(P.j_rotor > 0) || P.hand < 0 || P.hand > 2) {
        err = "impossible value (dt_s, pole_pairs, current_bw_hz, j_rotor_kg_m2 or hand_kind)";
        return false;
    }
    return true;
}

// floor(x), as std::floor, by a truncating conversion and a correction: the x86-64 baseline
// has no rounding instruction (SSE4.1's roundsd), and std::floor's inline expansion is twice
// as long. Exact for |x| < 2^52 (larger doubles are integers already, NaN and inf go to
// std::floor); only floor(-0.0) comes out +0.0, which its callers (the index test) cannot tell.
inline double floor_fast(double x) {
    if (!(std::fabs(x) < 4503599627370496.0)) return std::floor(x);
    const double t = static_cast<double>(static_cast<int64_t>(x));   // toward zero
    return t > x ? t - 1 : t;
}

// floor(x + 0.5) clipped to int8: y < -128 exactly when floor(y) < -128, y >= 128 exactly when
// floor(y) > 127; in between the truncation of y, one less for a negative non-integer, is
// floor(y) (the same codes as std::floor's, without its cost: six of these per microsecond).
inline int8_t quant(double x) {
    const double y = x + 0.5;
    if (y < -128) return -128;
    if (y >= 128) return 127;
    const int t = static_cast<int>(y);
    return static_cast<int8_t>(t > y ? t - 1 : t);
}

// sin(k phi) and cos(k (phi + ph)): the k-th harmonic on channels A and B. Without a
// quadrature error both channels share one argument: one sincos, whose values are glibc's sin
// and cos bit for bit.
inline void harmonic(double phi, double ph, int k, double* sk, double* ck) {
    if (ph == 0) {
        sincos(k * phi, sk, ck);
    } else {
        *sk = std::sin(k * phi);
        *ck = std::cos(k * (phi + ph));
    }
}

// The 2nd and 3rd harmonics, of weights h2 and h3, added to both channels. A function of its
// own, called only when there are any: the inlined encode_one (three copies in
// hg_plant_adc_mask's unrolled loop) stays small.
void add_harmonics(const Params& P, int i, double phi, double* sa, double* cb) {
    double sk, ck;
    if (P.h2[i] != 0) {
        harmonic(phi, P.phase[i], 2, &sk, &ck);
        *sa += P.h2[i] * sk;
        *cb += P.h2[i] * ck;
    }
    if (P.h3[i] != 0) {
        harmonic(phi, P.phase[i], 3, &sk, &ck);
        *sa += P.h3[i] * sk;
        *cb += P.h3[i] * ck;
    }
}

// The codes of axis i at `lines` with noise na, nb (LSB). Always inlined: gcc would keep it a
// call (it has three callers), whose register saves and argument passing cost a third of its
// own work in the every-microsecond hg_plant_adc_mask.
[[gnu::always_inline]] inline void encode_one(const Params& P, int i, double lines, double na,
                                              double nb, int8_t* a, int8_t* b) {
    const double phi = 2 * kPi * lines;
    double sa, cb;   // the fundamental, weight 1: exactly sin(phi) and cos(phi + ph)
    harmonic(phi, P.phase[i], 1, &sa, &cb);
    if (P.h2[i] != 0 || P.h3[i] != 0) add_harmonics(P, i, phi, &sa, &cb);
    *a = quant(P.amp[i] * P.gain_a[i] * sa + P.off_a[i] + na);
    *b = quant(P.amp[i] * P.gain_b[i] * cb + P.off_b[i] + nb);
    if (P.enc_swap[i]) std::swap(*a, *b);   // encoder_dir -1: A and B swapped at the connector
}

}  // namespace

extern "C" {

hg_plant* hg_plant_new(const char* config_text, char* err, int errlen) {
    Params P;
    std::string e;
    if (!parse(config_text, P, e)) {
        if (err && errlen > 0) std::snprintf(err, static_cast<size_t>(errlen), "%s", e.c_str());
        return nullptr;
    }
    auto* s = new hg_plant;
    s->P = P;
    s->hand0 = P.hand;
    s->path0 = P.path;
    s->rng = Rng(P.seed);
    s->t = P.t0;
    for (int i = 0; i < 3; ++i) {
        s->q[i] = s->qm[i] = P.q0[i];
        s->qd[i] = s->qdm[i] = 0;
    }
    s->compliant = P.k_link[0] != 0 || P.k_link[1] != 0 || P.k_link[2] != 0;
    s->alpha = 1.0 - std::exp(-2 * kPi * P.bw_hz * P.dt);
    s->alpha_us = 1.0 - std::exp(-2 * kPi * P.bw_hz * 1e-6);
    s->decay[0] = 1.0;
    for (int n = 1; n <= 64; ++n) s->decay[n] = s->decay[n - 1] * (1 - s->alpha_us);
    for (int n = 1; n <= 64; ++n) {
        double f = 0;
        for (int j = 1; j <= n; ++j) f += s->decay[j];
        s->mean_decay[n] = f / n;
    }
    winding_factors(s);
    s->m_end = P.m_link + P.m_handle;
    s->all_free = P.free_[0] && P.free_[1] && P.free_[2];
    s->coulomb = P.tau_c[0] != 0 || P.tau_c[1] != 0 || P.tau_c[2] != 0;
    s->path_sorted = true;
    for (size_t k = 4; k < P.path.size(); k += 4)
        s->path_sorted = s->path_sorted && P.path[k] >= P.path[k - 4];
    return s;
}

void hg_plant_free(hg_plant* p) { delete p; }

void hg_plant_set_dac(hg_plant* p, int ch, int code) {
    if (ch < 0 || ch > 5) return;
    double i = code / p->P.dac_fs * p->P.i_fs;
    i = i > p->P.i_max ? p->P.i_max : (i < -p->P.i_max ? -p->P.i_max : i);
    if (ch & 1)
        p->icmd_b[ch >> 1] = i;
    else
        p->icmd_a[ch >> 1] = i;
}

void hg_plant_hold(hg_plant* p, int on) {
    p->held = on != 0;
    p->have_prev = false;
}

void hg_plant_set_q(hg_plant* p, const double q[3], const double qd[3]) {
    for (int i = 0; i < 3; ++i) {
        p->q[i] = p->qm[i] = q[i];
        p->qd[i] = p->qdm[i] = qd[i];
    }
}

}  // extern "C"

namespace {

// The read-out of the present state (hg_plant_read) from its trigonometry and motor torques.
void fill_out(const hg_plant* s, const Trig& kq, const double* tau, const double* th, hg_plant_out* o) {
    const Params& P = s->P;
    o->t = s->t;
    double J[9];
    jac_t(P.arm, kq, J);
    fk_t(P.arm, kq, o->p);
    for (int i = 0; i < 3; ++i) {
        o->q[i] = s->q[i];
        o->qd[i] = s->qd[i];
        o->f_hand[i] = s->f_hand[i];
        o->tau[i] = tau[i];
        o->theta_e[i] = th[i];
        o->i_ab[2 * i] = s->ia[i];
        o->i_ab[2 * i + 1] = s->ib[i];
        o->v[i] = 0;
        for (int c = 0; c < 3; ++c) o->v[i] += J[3 * i + c] * s->qd[c];
    }
    const double m = s->m_end;
    double e = 0;
    for (int i = 0; i < 3; ++i) {
        e += 0.5 * (m * o->v[i] * o->v[i] + P.j_rotor * s->qdm[i] * s->qdm[i]);
        const double dq = s->qm[i] - s->q[i];
        e += 0.5 * P.k_link[i] * dq * dq;
        o->qm[i] = s->qm[i];
        o->qdm[i] = s->qdm[i];
    }
    if (P.hand == 1) {
        double pt[3], vt[3];
        target(s, s->t, pt, vt);
        for (int i = 0; i < 3; ++i) e += 0.5 * P.hand_k * (pt[i] - o->p[i]) * (pt[i] - o->p[i]);
    }
    o->energy = e;
}

// sin and cos of the joint angles for mech_step, and of pole_pairs times them (the motors'
// electrical angles but for the index offset, which torque_pq's factors hold): exact (sincos)
// every kTrigResync steps and after a jump of more than 0.01 rad, else the last step's rotated
// by its change d (Taylor to d^5: the rotation is exact to ~1e-18 for |d| < 0.01, so the values
// stay within a few ulp of sincos between resyncs); pole_pairs * q from the joint's by complex
// powers. (A joint that did not move, d = 0, is rotated by exactly 1 + 0i.)
constexpr int kTrigResync = 64;
void joint_trig(hg_plant* s, double* sp, double* cp) {
    const int pp = s->P.pole_pairs;
    double d[3];   // each joint's change since the last step: the jump test and the rotation
    bool exact = s->tc_age == 0 || s->tc_age >= kTrigResync;
#pragma GCC unroll 3
    for (int i = 0; i < 3; ++i) {
        d[i] = s->q[i] - s->tc_q[i];
        exact = exact || !(std::fabs(d[i]) <= 1e-2);
    }
    if (exact) {
        for (int i = 0; i < 3; ++i) sincos(s->q[i], &s->tc_s[i], &s->tc_c[i]);
        s->tc_age = 1;
    } else {
#pragma GCC unroll 3
        for (int i = 0; i < 3; ++i) {
            const double d2 = d[i] * d[i];
            const double cd = 1 - d2 * (0.5 - d2 * (1.0 / 24));
            const double sd = d[i] * (1 - d2 * (1.0 / 6 - d2 * (1.0 / 120)));
            const double c0 = s->tc_c[i], s0 = s->tc_s[i];
            s->tc_c[i] = c0 * cd - s0 * sd;
            s->tc_s[i] = s0 * cd + c0 * sd;
        }
        ++s->tc_age;
    }
#pragma GCC unroll 3
    for (int i = 0; i < 3; ++i) {
        s->tc_q[i] = s->q[i];
        // (cos + i sin)^pole_pairs from the first power on (the product by 1 + 0i is exact);
        // the paper's motors' square written out (the same operations as the loop's)
        const double c = s->tc_c[i], sj = s->tc_s[i];
        double cr = c, sr = sj;
        if (pp == 2) {
            cr = c * c - sj * sj;
            sr = sj * c + c * sj;
        } else {
            for (int k = 1; k < pp; ++k) {
                const double c2 = cr * c - sr * sj;
                sr = sr * c + cr * sj;
                cr = c2;
            }
        }
        sp[i] = sr;
        cp[i] = cr;
    }
}

// A mechanics step's motor torques from the currents (ia, ib) at the electrical angles' sines
// and cosines (sp, cp), the read-out of the state before the step (out, if asked: the
// amplifier's present currents at the same angles) and the Jacobian at the joints' kq. Shared by
// both mechanics steps.
[[gnu::always_inline]] inline void step_torques(hg_plant* s, const double* ia, const double* ib,
                                                const double* sp, const double* cp,
                                                const Trig& kq, hg_plant_out* out,
                                                double* tau, double* J) {
    torque_pq(s, ia, ib, sp, cp, tau);
    if (out) {
        double th[3], tau_now[3];
        elec_angles(s, th);
        torque_pq(s, s->ia, s->ib, sp, cp, tau_now);
        fill_out(s, kq, tau_now, th, out);
    }
    for (int i = 0; i < 3; ++i) s->tau[i] = tau[i];
    jac_t(s->P.arm, kq, J);
}

// The spring hand's force on the device at the step's pose (fdev; the hand's own, f_hand, is
// its negative): k (p_target - p) + b (v_target - J qd). Shared by both mechanics steps.
[[gnu::always_inline]] inline void hand_force(hg_plant* s, const Trig& kq, const double* J,
                                              const double* qd, double* fdev) {
    const Params& P = s->P;
    double p[3], pt[3], vt[3];
    fk_t(P.arm, kq, p);
    target(s, s->t, pt, vt);
#pragma GCC unroll 3
    for (int i = 0; i < 3; ++i) {
        const double v = J[3 * i] * qd[0] + J[3 * i + 1] * qd[1] + J[3 * i + 2] * qd[2];
        fdev[i] = P.hand_k * (pt[i] - p[i]) + P.hand_b * (vt[i] - v);
    }
    for (int i = 0; i < 3; ++i) s->f_hand[i] = -fdev[i];
}

// The endpoint mass's Coriolis/centrifugal force taken from w: m Jdot qd, Jdot qd = (J - Jprev)
// qd / dt (m_dt = m / dt: one division instead of one per element).
[[gnu::always_inline]] inline void coriolis(const hg_plant* s, const double* J,
                                            const double* qd, double m_dt, double* w) {
    const double* Jp = s->Jprev;
#pragma GCC unroll 3
    for (int r = 0; r < 3; ++r)
        w[r] -= m_dt * ((J[3 * r] - Jp[3 * r]) * qd[0] + (J[3 * r + 1] - Jp[3 * r + 1]) * qd[1] +
                        (J[3 * r + 2] - Jp[3 * r + 2]) * qd[2]);
}

// A held joint (an axis not simulated) in the mass matrix's system: its row and column the
// identity's and its right-hand side 0, so its qdd is 0 and the free joints get the reduced
// system's solution (solve_spd3: the zeros enter only as exact products).
inline void hold_rows(const bool* fr, double& m00, double& m01, double& m02, double& m11,
                      double& m12, double& m22, double* b) {
    if (!fr[0]) { m00 = 1; m01 = m02 = 0; b[0] = 0; }
    if (!fr[1]) { m11 = 1; m01 = m12 = 0; b[1] = 0; }
    if (!fr[2]) { m22 = 1; m02 = m12 = 0; b[2] = 0; }
}

// One semi-implicit Euler step of dt with the motor torques of phase currents (ia, ib); with
// `out`, the read-out of the state before the step as well (its trigonometry shared).
// This is the plant's cost per simulated microsecond: it works on locals (after a store
// through s the compiler must reload every double of s), forms each product once and solves
// the mass matrix in closed form (solve_spd3). Its loops over the three joints, and those of
// joint_trig, torque_pq, hg_plant_step and hg_plant_adc_mask, are unrolled (#pragma GCC
// unroll 3): at -O2 gcc keeps them loops with their values in memory; written out, the values
// stay in registers (a quarter of the step's instructions).
void mech_step_compliant(hg_plant* s, double dt, const double* ia, const double* ib,
                         hg_plant_out* out);

void mech_step(hg_plant* s, double dt, const double* ia, const double* ib, hg_plant_out* out = nullptr) {
    if (s->compliant) {
        mech_step_compliant(s, dt, ia, ib, out);
        return;
    }
    const Params& P = s->P;
    const double m = s->m_end;
    double sp[3], cp[3], tau[3];
    joint_trig(s, sp, cp);
    const Trig kq = trig_sc(s->tc_s, s->tc_c);
    double J[9];
    step_torques(s, ia, ib, sp, cp, kq, out, tau, J);
    const double qd[3] = {s->qd[0], s->qd[1], s->qd[2]};
    double tq[3] = {tau[0], tau[1], tau[2]};
    if (P.gravity) {
        double g[3];
        grad_u(P, kq, g);
        for (int i = 0; i < 3; ++i) tq[i] -= g[i];
    }
    double fdev[3] = {0, 0, 0};
    if (P.hand == 1) hand_force(s, kq, J, qd, fdev);
    const bool fixed = P.hand == 2;
    if (fixed || s->held) {
        if (fixed) {  // rigid grip: static equilibrium tau + J^T F_dev = 0, F_hand = -F_dev
            double a[3][3], b[3];
            for (int r = 0; r < 3; ++r) {
                b[r] = tq[r];
                for (int c = 0; c < 3; ++c) a[r][c] = J[3 * c + r];  // J^T
            }
            solve(a, b, 3);
            for (int i = 0; i < 3; ++i) s->f_hand[i] = b[i];
        }
        if (s->held)
            for (int i = 0; i < 3; ++i) s->qm[i] = s->q[i] += dt * qd[i];
        s->have_prev = false;
        s->t += dt;
        return;
    }
    // joint-space dynamics with the linkage mass lumped at the endpoint:
    // (J_r I + m J^T J) qdd = tau + J^T w - friction,  w = F_dev - m Jdot qd,
    // Jdot qd = (J - Jprev) qd / dt (one division, m / dt, instead of one per element)
    double w[3] = {fdev[0], fdev[1], fdev[2]};
    if (s->have_prev) coriolis(s, J, qd, m / dt, w);
    double b[3];
#pragma GCC unroll 3
    for (int i = 0; i < 3; ++i) {
        double acc = tq[i] + J[i] * w[0] + J[3 + i] * w[1] + J[6 + i] * w[2];
        acc -= P.b_visc[i] * qd[i];
        if (s->coulomb && P.tau_c[i] != 0) acc -= P.tau_c[i] * std::tanh(qd[i] / P.coulomb_w);
        b[i] = acc;
    }
    // M = J_r I + m J^T J: symmetric, its six distinct entries (dot products of J's columns)
    const double jr = P.j_rotor;
    double m00 = m * (J[0] * J[0] + J[3] * J[3] + J[6] * J[6]) + jr;
    double m11 = m * (J[1] * J[1] + J[4] * J[4] + J[7] * J[7]) + jr;
    double m22 = m * (J[2] * J[2] + J[5] * J[5] + J[8] * J[8]) + jr;
    double m01 = m * (J[0] * J[1] + J[3] * J[4] + J[6] * J[7]);
    double m02 = m * (J[0] * J[2] + J[3] * J[5] + J[6] * J[8]);
    double m12 = m * (J[1] * J[2] + J[4] * J[5] + J[7] * J[8]);
    if (!s->all_free) hold_rows(P.free_, m00, m01, m02, m11, m12, m22, b);
    solve_spd3(m00, m01, m02, m11, m12, m22, b);
    // semi-implicit (symplectic) Euler
#pragma GCC unroll 3
    for (int i = 0; i < 3; ++i) {
        const double qdn = P.free_[i] ? qd[i] + dt * b[i] : 0;
        s->qd[i] = s->qdm[i] = qdn;
        s->qm[i] = s->q[i] += dt * qdn;   // rigid: the rotor is the joint
    }
    std::memcpy(s->Jprev, J, sizeof J);
    s->have_prev = true;
    s->t += dt;
}

// mech_step with link compliance (README "Link compliance"): per joint the rotor (inertia
// j_rotor, the winding's torque, the bearing's viscous and Coulomb friction; the encoder reads
// its angle qm) and the linkage (the endpoint mass through J, the hand, gravity) coupled by
// tau_s = k (qm - q) + b (qdm - qd). Semi-implicit Euler on both; exact trigonometry each step
// (the rigid step's rotation shortcut is not used: this path is an option, not the default).
//   J_r qdd_m = tau - b_visc qdm - coulomb(qdm) - tau_s
//   m J^T J qdd = J^T w + tau_s - grad U,  w = F_dev - m Jdot qd
// A rigid grip holds the linkage (qd = 0): the rotors move against the springs and the hand's
// force is the static J^T F = -tau_s (+ gravity); a held joint (fixture) moves both sides.
void mech_step_compliant(hg_plant* s, double dt, const double* ia, const double* ib,
                         hg_plant_out* out) {
    const Params& P = s->P;
    const double m = s->m_end;
    double sp[3], cp[3], tau[3];
    for (int i = 0; i < 3; ++i) sincos(P.pole_pairs * s->qm[i], &sp[i], &cp[i]);
    const Trig kq = trig(s->q);
    double J[9];
    step_torques(s, ia, ib, sp, cp, kq, out, tau, J);
    const double qd[3] = {s->qd[0], s->qd[1], s->qd[2]};
    double ts[3], gq[3] = {0, 0, 0};
    for (int i = 0; i < 3; ++i)
        ts[i] = P.k_link[i] * (s->qm[i] - s->q[i]) + P.b_link[i] * (s->qdm[i] - qd[i]);
    if (P.gravity) grad_u(P, kq, gq);
    double fdev[3] = {0, 0, 0};
    if (P.hand == 1) hand_force(s, kq, J, qd, fdev);
    if (s->held) {   // the fixture moves both sides together
        for (int i = 0; i < 3; ++i) {
            s->q[i] += dt * qd[i];
            s->qm[i] = s->q[i];
            s->qdm[i] = qd[i];
        }
        s->have_prev = false;
        s->t += dt;
        return;
    }
    // the rotors
    for (int i = 0; i < 3; ++i) {
        double acc = tau[i] - P.b_visc[i] * s->qdm[i] - ts[i];
        if (s->coulomb && P.tau_c[i] != 0) acc -= P.tau_c[i] * std::tanh(s->qdm[i] / P.coulomb_w);
        const double qdn = P.free_[i] ? s->qdm[i] + dt * acc / P.j_rotor : 0;
        s->qdm[i] = qdn;
        s->qm[i] += dt * qdn;
    }
    if (P.hand == 2) {   // rigid grip: the linkage held, J^T F_dev + tau_s - grad U = 0
        double a[3][3], b[3];
        for (int r = 0; r < 3; ++r) {
            b[r] = ts[r] - gq[r];
            for (int c = 0; c < 3; ++c) a[r][c] = J[3 * c + r];
        }
        solve(a, b, 3);
        for (int i = 0; i < 3; ++i) {
            s->f_hand[i] = b[i];
            s->qd[i] = 0;
        }
        s->have_prev = false;
        s->t += dt;
        return;
    }
    // the linkage
    double w[3] = {fdev[0], fdev[1], fdev[2]};
    if (s->have_prev) coriolis(s, J, qd, m / dt, w);
    double b[3];
    for (int i = 0; i < 3; ++i) b[i] = ts[i] - gq[i] + J[i] * w[0] + J[3 + i] * w[1] + J[6 + i] * w[2];
    double m00 = m * (J[0] * J[0] + J[3] * J[3] + J[6] * J[6]);
    double m11 = m * (J[1] * J[1] + J[4] * J[4] + J[7] * J[7]);
    double m22 = m * (J[2] * J[2] + J[5] * J[5] + J[8] * J[8]);
    double m01 = m * (J[0] * J[1] + J[3] * J[4] + J[6] * J[7]);
    double m02 = m * (J[0] * J[2] + J[3] * J[5] + J[6] * J[8]);
    double m12 = m * (J[1] * J[2] + J[4] * J[5] + J[7] * J[8]);
    if (!s->all_free) hold_rows(P.free_, m00, m01, m02, m11, m12, m22, b);
    solve_spd3(m00, m01, m02, m11, m12, m22, b);
    for (int i = 0; i < 3; ++i) {
        const double qdn = P.free_[i] ? qd[i] + dt * b[i] : 0;
        s->qd[i] = qdn;
        s->q[i] += dt * qdn;
    }
    std::memcpy(s->Jprev, J, sizeof J);
    s->have_prev = true;
    s->t += dt;
}

}  // namespace

extern "C" {

void hg_plant_step(hg_plant* s, int n) {
    const double alpha = s->alpha, dt = s->P.dt;   // (locals: not reloaded after each store to s)
    for (int k = 0; k < n; ++k) {
        // amplifier: first-order current loop toward the (limited) commands, exact for a
        // command held over the step
#pragma GCC unroll 3
        for (int i = 0; i < 3; ++i) {
            s->ia[i] += (s->icmd_a[i] - s->ia[i]) * alpha;
            s->ib[i] += (s->icmd_b[i] - s->ib[i]) * alpha;
        }
        mech_step(s, dt, s->ia, s->ib);
    }
}

void hg_plant_amp_us(hg_plant* s) {
    for (int i = 0; i < 3; ++i) {
        s->ia[i] += (s->icmd_a[i] - s->ia[i]) * s->alpha_us;
        s->ib[i] += (s->icmd_b[i] - s->ib[i]) * s->alpha_us;
    }
}

void hg_plant_amp(hg_plant* s, int n_us) {
    if (n_us <= 0) return;
    const double r = n_us <= 64 ? s->decay[n_us] : std::pow(1 - s->alpha_us, n_us);
    for (int i = 0; i < 3; ++i) {
        s->ia[i] = s->icmd_a[i] + (s->ia[i] - s->icmd_a[i]) * r;
        s->ib[i] = s->icmd_b[i] + (s->ib[i] - s->icmd_b[i]) * r;
    }
}

void hg_plant_held_us(hg_plant* s) {
    hg_plant_amp_us(s);
    for (int i = 0; i < 3; ++i) {
        s->q[i] += 1e-6 * s->qd[i];
        s->qm[i] += 1e-6 * s->qdm[i];
    }
    s->have_prev = false;
    s->t += 1e-6;
}

void hg_plant_mech_read(hg_plant* s, int n_us, hg_plant_out* out) {
    // the mean over the next n_us of the currents the amplifier reaches with today's commands
    // (the 1 us updates that hg_plant_amp_us makes): cmd + (i0 - cmd) * mean_j (1 - alpha)^j
    double f = 0;
    if (n_us <= 64) {
        f = s->mean_decay[n_us];
    } else {
        double r = 1;
        for (int j = 1; j <= n_us; ++j) {
            r *= 1 - s->alpha_us;
            f += r;
        }
        f /= n_us;
    }
    double ia[3], ib[3];
    for (int i = 0; i < 3; ++i) {
        ia[i] = s->icmd_a[i] + (s->ia[i] - s->icmd_a[i]) * f;
        ib[i] = s->icmd_b[i] + (s->ib[i] - s->icmd_b[i]) * f;
    }
    mech_step(s, n_us * 1e-6, ia, ib, out);
}

void hg_plant_mech(hg_plant* s, int n_us) { hg_plant_mech_read(s, n_us, nullptr); }

void hg_plant_adc(hg_plant* s, int8_t a[3], int8_t b[3], uint8_t idx[3]) {
    hg_plant_adc_mask(s, 7, a, b, idx);
}

void hg_plant_adc_mask(hg_plant* s, int mask, int8_t a[3], int8_t b[3], uint8_t idx[3]) {
    const Params& P = s->P;
#pragma GCC unroll 3
    for (int i = 0; i < 3; ++i) {
        if (!((mask >> i) & 1)) continue;
        const double x = (s->qm[i] - P.q_index[i]) / (2 * kPi) * P.lines;
        double na = 0, nb = 0;
        if (P.noise[i] > 0) {
            na = P.noise[i] * s->rng.normal();
            nb = P.noise[i] * s->rng.normal();
        }
        encode_one(P, i, x, na, nb, &a[i], &b[i]);
        // index: quadrant 0 of line 0 (modulo the lines per revolution). The quadrant test
        // first: it fails for 3/4 of the samples, which then need no division for the modulo.
        const double line = floor_fast(x);
        idx[i] = (x - line < 0.25 && line - P.lines * floor_fast(line / P.lines) == 0.0) ? 1 : 0;
    }
}

void hg_plant_read(const hg_plant* s, hg_plant_out* o) {
    double th[3], tau[3];
    const Trig kq = trig(s->q);   // (one evaluation for both)
    motor_torque(s, tau, th);
    fill_out(s, kq, tau, th, o);
}

void hg_plant_q(const hg_plant* p, double q[3]) {
    for (int i = 0; i < 3; ++i) q[i] = p->qm[i];
}

void hg_plant_fk(const hg_plant* p, const double q[3], double out[3]) { fk(p->P.arm, q, out); }
void hg_plant_jac(const hg_plant* p, const double q[3], double out[9]) { jac(p->P.arm, q, out); }

void hg_plant_encode(const hg_plant* p, int axis, const double* lines, int n, int8_t* a, int8_t* b) {
    for (int k = 0; k < n; ++k) encode_one(p->P, axis, lines[k], 0, 0, &a[k], &b[k]);
}

void hg_plant_encode1(const hg_plant* p, int axis, double lines, double za, double zb, int8_t* a, int8_t* b) {
    encode_one(p->P, axis, lines, p->P.noise[axis] * za, p->P.noise[axis] * zb, a, b);
}

double hg_plant_noise_lsb(const hg_plant* p, int axis) { return p->P.noise[axis]; }

void hg_plant_set_hand(hg_plant* s, int kind, const double* path, int n) {
    if (s->hand0 == 2) return;   // a rigid grip holds on
    if (kind < 0) {
        s->P.hand = s->hand0;
        s->P.path = s->path0;
    } else {
        s->P.hand = kind;
        if (path) s->P.path.assign(path, path + 4 * n);
    }
    s->path_seg = 0;
}

void hg_plant_set_target(hg_plant* s, const double xyz[3]) {
    s->P.path = {0.0, xyz[0], xyz[1], xyz[2]};
    s->path_seg = 0;
}

}  // extern "C"
