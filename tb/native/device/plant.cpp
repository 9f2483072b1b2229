// SPDX-License-Identifier: Apache-2.0
// The plant of the virtual device (see plant.h and README.md): motors + amplifiers, linkage
// dynamics with a hand, encoder front end. Double precision throughout, no allocation in the
// step, no dependence on the firmware (the firmware is what it tests).
#include "plant.h"

#include <cmath>
#include <cstdio>
#include <cstring>
#include <map>
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
    double dac_fs = 8191.0;
    double arm = 0.05;                // m, L_beta = L_gamma (KINEMATICS.md)
    double m_link = 0.02, m_handle = 0.01;  // kg, lumped at the endpoint
    double b_visc[3] = {2e-4, 2e-4, 2e-4};  // N m s / rad
    double tau_c[3] = {0, 0, 0};            // N m, Coulomb
    double coulomb_w = 1e-3;                // rad/s, width of the regularised sign
    bool gravity = false;
    double gk[12] = {0};
    double q_ab = 0, q_ac = 0;
    int hand = 0;                     // 0 none, 1 spring, 2 fixed
    double hand_k = 500.0, hand_b = 2.0;
    std::vector<double> path;         // t, x, y, z per point
    double amp[3] = {110, 110, 110}, off_a[3] = {0, 0, 0}, off_b[3] = {0, 0, 0};
    double gain_a[3] = {1, 1, 1}, gain_b[3] = {1, 1, 1}, phase[3] = {0, 0, 0};  // phase in rad
    double h2[3] = {0, 0, 0}, h3[3] = {0, 0, 0}, noise[3] = {0, 0, 0};
    double q_index[3] = {0, 0, 0};    // rad: joint angle of the index = winding zero
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
    Rng rng;
    double t = 0;
    double q[3], qd[3];
    double ia[3] = {0, 0, 0}, ib[3] = {0, 0, 0};
    double icmd_a[3] = {0, 0, 0}, icmd_b[3] = {0, 0, 0};
    double alpha = 0;                 // current-loop step factor
    double alpha_us = 0;              // the same for 1 us (hg_plant_amp_us)
    double decay[65] = {0};           // (1 - alpha_us)^n, n = 0..64
    double mean_decay[65] = {0};      // mean over j = 1..n of (1 - alpha_us)^j
    double J[9], Jprev[9];
    bool have_prev = false, held = false;
    double tau[3] = {0, 0, 0}, f_hand[3] = {0, 0, 0};
    // mech_step's joint trigonometry (joint_trig): sin, cos of tc_q, steps since exact
    double tc_s[3] = {0, 0, 0}, tc_c[3] = {1, 1, 1}, tc_q[3] = {0, 0, 0};
    int tc_age = 0;
    double pi_s[3] = {0, 0, 0}, pi_c[3] = {1, 1, 1};   // sin, cos of pole_pairs * q_index
};

namespace {

struct Trig { double ca, sa, cb, sb, cg, sg, db, dg; };

inline Trig trig_sc(const double* sn, const double* cs) {   // from sin, cos of the joints
    Trig r;
    r.sa = sn[0]; r.ca = cs[0];
    r.sb = sn[1]; r.cb = cs[1];
    r.sg = sn[2]; r.cg = cs[2];
    r.db = std::sqrt(r.cb * r.cb + r.ca * r.ca * r.sb * r.sb);
    r.dg = std::sqrt(r.cg * r.cg + r.ca * r.ca * r.sg * r.sg);
    return r;
}

inline Trig trig(const double* q) {
    double sn[3], cs[3];
    for (int i = 0; i < 3; ++i) sincos(q[i], &sn[i], &cs[i]);
    return trig_sc(sn, cs);
}

void fk_t(double L, const Trig& k, double* p) {
    const double rho = L * k.cb / k.db + L * k.cg / k.dg;
    p[0] = -rho * k.sa;
    p[1] = rho * k.ca;
    p[2] = k.ca * (-L * k.sb / k.db + L * k.sg / k.dg);
}

// J = dp/dq (row-major), KINEMATICS.md with h = 0.
void jac_t(double L, const Trig& k, double* m) {
    const double ca = k.ca, sa = k.sa, cb = k.cb, sb = k.sb, cg = k.cg, sg = k.sg;
    const double kb = L / (k.db * k.db * k.db), kg = L / (k.dg * k.dg * k.dg);
    m[0] = kb * -ca * cb + kg * -ca * cg;
    m[3] = kb * -sa * cb * cb * cb + kg * -sa * cg * cg * cg;
    m[6] = kb * sa * sb * cb * cb + kg * -sa * sg * cg * cg;
    m[1] = kb * ca * sa * ca * sb;
    m[4] = kb * ca * -ca * ca * sb;
    m[7] = kb * ca * -cb;
    m[2] = kg * ca * sa * ca * sg;
    m[5] = kg * ca * -ca * ca * sg;
    m[8] = kg * ca * cg;
}

void fk(double L, const double* q, double* p) { fk_t(L, trig(q), p); }
void jac(double L, const double* q, double* m) { jac_t(L, trig(q), m); }

// dU/dq, the paper's equations (2)-(4) (independent of the firmware's copy).
void grad_u(const Params& P, const double* q, double* g) {
    const double sa = std::sin(q[0]), ca = std::cos(q[0]), sb = std::sin(q[1]), cb = std::cos(q[1]);
    const double sg = std::sin(q[2]), cg = std::cos(q[2]);
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
// partial pivoting, in place.
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

void target(const Params& P, double t, double* pt, double* vt) {
    const int n = static_cast<int>(P.path.size() / 4);
    for (int i = 0; i < 3; ++i) vt[i] = 0;
    if (n == 0) {
        for (int i = 0; i < 3; ++i) pt[i] = 0;
        return;
    }
    const double* w = P.path.data();
    if (t <= w[0] || n == 1) {
        for (int i = 0; i < 3; ++i) pt[i] = w[1 + i];
        return;
    }
    for (int k = 0; k + 1 < n; ++k) {
        const double t0 = w[4 * k], t1 = w[4 * k + 4];
        if (t < t1) {  // smoothstep: C1, zero velocity at every point
            const double h = t1 - t0, u = (t - t0) / h;
            const double s = u * u * (3 - 2 * u), ds = 6 * u * (1 - u) / h;
            for (int i = 0; i < 3; ++i) {
                const double d = w[4 * k + 5 + i] - w[4 * k + 1 + i];
                pt[i] = w[4 * k + 1 + i] + d * s;
                vt[i] = d * ds;
            }
            return;
        }
    }
    for (int i = 0; i < 3; ++i) pt[i] = w[4 * (n - 1) + 1 + i];
}

// Motor torques from the phase currents at the true electrical angles:
// tau = kt * 2/3 * (ia sin(te) + ib sin(te - 120) + ic sin(te - 240)), ic = -(ia + ib)
//     = kt * 2/3 * (ia (sin te - sin(te - 240)) + ib (sin(te - 120) - sin(te - 240)))
//     = kt * 2/3 * sqrt(3) * (ia cos(te - 120) - ib cos(te))   (sum to product)
// (tau2: optionally the torques of the amplifier's present currents as well, same angles)
// (ste, cte: sin and cos of the electrical angles when the caller has them, else evaluated)
void motor_torque_i(const hg_plant* s, const double* ia, const double* ib, double* tau, double* th,
                    double* tau2 = nullptr, const double* ste = nullptr, const double* cte = nullptr) {
    const Params& P = s->P;
    constexpr double kS120 = 0.86602540378443864676, kSqrt3 = 1.7320508075688772935;
    for (int m = 0; m < 3; ++m) {
        const double te = P.pole_pairs * (s->q[m] - P.q_index[m]);
        th[m] = te;
        double st, ct;
        if (ste) {
            st = ste[m];
            ct = cte[m];
        } else {
            sincos(te, &st, &ct);
        }
        tau[m] = P.kt * (2.0 / 3.0) * kSqrt3 * (ia[m] * (kS120 * st - 0.5 * ct) - ib[m] * ct);
        if (tau2) tau2[m] = P.kt * (2.0 / 3.0) * kSqrt3 * (s->ia[m] * (kS120 * st - 0.5 * ct) - s->ib[m] * ct);
    }
}

void motor_torque(const hg_plant* s, double* tau, double* th) { motor_torque_i(s, s->ia, s->ib, tau, th); }

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
              take("seed", &seed, 1) && take("lines", &P.lines, 1);
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
    }
    if (!(P.dt > 0) || P.pole_pairs < 1 || !(P.bw_hz > 0) || !(P.j_rotor > 0) || P.hand < 0 || P.hand > 2) {
        err = "impossible value (dt_s, pole_pairs, current_bw_hz, j_rotor_kg_m2 or hand_kind)";
        return false;
    }
    return true;
}

inline int8_t quant(double x) {
    const double r = std::floor(x + 0.5);
    return static_cast<int8_t>(r < -128 ? -128 : (r > 127 ? 127 : r));
}

void encode_one(const Params& P, int i, double lines, double na, double nb, int8_t* a, int8_t* b) {
    const double phi = 2 * kPi * lines;
    const double ph = P.phase[i];
    // The k-th harmonic of weight h on both channels (k = 1: the fundamental, weight 1, exactly
    // sin(phi) and cos(phi + ph)). Without a quadrature error both channels share one argument:
    // one sincos, whose values are glibc's sin and cos bit for bit.
    double sa = 0, cb = 0;
    const auto harmonic = [&](int k, double h) {
        double sk, ck;
        if (ph == 0) {
            sincos(k * phi, &sk, &ck);
        } else {
            sk = std::sin(k * phi);
            ck = std::cos(k * (phi + ph));
        }
        sa += h * sk;
        cb += h * ck;
    };
    harmonic(1, 1.0);
    if (P.h2[i] != 0) harmonic(2, P.h2[i]);
    if (P.h3[i] != 0) harmonic(3, P.h3[i]);
    *a = quant(P.amp[i] * P.gain_a[i] * sa + P.off_a[i] + na);
    *b = quant(P.amp[i] * P.gain_b[i] * cb + P.off_b[i] + nb);
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
    s->rng = Rng(P.seed);
    s->t = P.t0;
    for (int i = 0; i < 3; ++i) {
        s->q[i] = P.q0[i];
        s->qd[i] = 0;
    }
    s->alpha = 1.0 - std::exp(-2 * kPi * P.bw_hz * P.dt);
    s->alpha_us = 1.0 - std::exp(-2 * kPi * P.bw_hz * 1e-6);
    s->decay[0] = 1.0;
    for (int n = 1; n <= 64; ++n) s->decay[n] = s->decay[n - 1] * (1 - s->alpha_us);
    for (int n = 1; n <= 64; ++n) {
        double f = 0;
        for (int j = 1; j <= n; ++j) f += s->decay[j];
        s->mean_decay[n] = f / n;
    }
    jac(P.arm, s->q, s->J);
    for (int i = 0; i < 3; ++i) sincos(P.pole_pairs * P.q_index[i], &s->pi_s[i], &s->pi_c[i]);
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
        p->q[i] = q[i];
        p->qd[i] = qd[i];
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
    const double m = P.m_link + P.m_handle;
    double e = 0;
    for (int i = 0; i < 3; ++i) e += 0.5 * (m * o->v[i] * o->v[i] + P.j_rotor * s->qd[i] * s->qd[i]);
    if (P.hand == 1) {
        double pt[3], vt[3];
        target(P, s->t, pt, vt);
        for (int i = 0; i < 3; ++i) e += 0.5 * P.hand_k * (pt[i] - o->p[i]) * (pt[i] - o->p[i]);
    }
    o->energy = e;
}

// sin and cos of the joint angles for mech_step, and of the motors' electrical angles: exact
// (sincos) every kTrigResync steps and after a jump of more than 0.01 rad, else the last step's
// rotated by its change d (Taylor to d^5: the rotation is exact to ~1e-18 for |d| < 0.01, so
// the values stay within a few ulp of sincos between resyncs); the electrical angles'
// pole_pairs * (q - q_index) from the joint's by complex powers and a fixed rotation.
constexpr int kTrigResync = 64;
void joint_trig(hg_plant* s, double* ste, double* cte) {
    const Params& P = s->P;
    bool exact = s->tc_age == 0 || s->tc_age >= kTrigResync;
    for (int i = 0; i < 3 && !exact; ++i) exact = !(std::fabs(s->q[i] - s->tc_q[i]) <= 1e-2);
    if (exact) {
        for (int i = 0; i < 3; ++i) sincos(s->q[i], &s->tc_s[i], &s->tc_c[i]);
        s->tc_age = 1;
    } else {
        for (int i = 0; i < 3; ++i) {
            const double d = s->q[i] - s->tc_q[i];
            if (d == 0) continue;
            const double d2 = d * d;
            const double cd = 1 - d2 * (0.5 - d2 * (1.0 / 24));
            const double sd = d * (1 - d2 * (1.0 / 6 - d2 * (1.0 / 120)));
            const double sn = s->tc_s[i] * cd + s->tc_c[i] * sd;
            s->tc_c[i] = s->tc_c[i] * cd - s->tc_s[i] * sd;
            s->tc_s[i] = sn;
        }
        ++s->tc_age;
    }
    for (int i = 0; i < 3; ++i) {
        s->tc_q[i] = s->q[i];
        double cr = 1, sr = 0;   // (cos + i sin)^pole_pairs
        for (int k = 0; k < P.pole_pairs; ++k) {
            const double c2 = cr * s->tc_c[i] - sr * s->tc_s[i];
            sr = sr * s->tc_c[i] + cr * s->tc_s[i];
            cr = c2;
        }
        ste[i] = sr * s->pi_c[i] - cr * s->pi_s[i];   // minus pole_pairs * q_index
        cte[i] = cr * s->pi_c[i] + sr * s->pi_s[i];
    }
}

// One semi-implicit Euler step of dt with the motor torques of phase currents (ia, ib); with
// `out`, the read-out of the state before the step as well (its trigonometry shared).
void mech_step(hg_plant* s, double dt, const double* ia, const double* ib, hg_plant_out* out = nullptr) {
    const Params& P = s->P;
    const double m = P.m_link + P.m_handle;
    double th[3], tau_now[3], ste[3], cte[3];
    joint_trig(s, ste, cte);
    motor_torque_i(s, ia, ib, s->tau, th, out ? tau_now : nullptr, ste, cte);
    const Trig kq = trig_sc(s->tc_s, s->tc_c);
    if (out) fill_out(s, kq, tau_now, th, out);
    jac_t(P.arm, kq, s->J);
    double p[3], v[3] = {0, 0, 0}, pt[3], vt[3], fdev[3] = {0, 0, 0};
    if (P.hand == 1) fk_t(P.arm, kq, p);
    for (int r = 0; r < 3; ++r)
        for (int c = 0; c < 3; ++c) v[r] += s->J[3 * r + c] * s->qd[c];
    double tq[3];
    for (int i = 0; i < 3; ++i) tq[i] = s->tau[i];
    if (P.gravity) {
        double g[3];
        grad_u(P, s->q, g);
        for (int i = 0; i < 3; ++i) tq[i] -= g[i];
    }
    if (P.hand == 1) {
        target(P, s->t, pt, vt);
        for (int i = 0; i < 3; ++i) fdev[i] = P.hand_k * (pt[i] - p[i]) + P.hand_b * (vt[i] - v[i]);
        for (int i = 0; i < 3; ++i) s->f_hand[i] = -fdev[i];
    }
    const bool fixed = P.hand == 2;
    if (fixed || s->held) {
        if (fixed) {  // rigid grip: static equilibrium tau + J^T F_dev = 0, F_hand = -F_dev
            double a[3][3], b[3];
            for (int r = 0; r < 3; ++r) {
                b[r] = tq[r];
                for (int c = 0; c < 3; ++c) a[r][c] = s->J[3 * c + r];  // J^T
            }
            solve(a, b, 3);
            for (int i = 0; i < 3; ++i) s->f_hand[i] = b[i];
        }
        if (s->held)
            for (int i = 0; i < 3; ++i) s->q[i] += dt * s->qd[i];
        s->have_prev = false;
        s->t += dt;
        return;
    }
    // joint-space dynamics with the linkage mass lumped at the endpoint:
    // (J_r I + m J^T J) qdd = tau + J^T F_dev - m J^T (Jdot qd) - friction
    double jdq[3] = {0, 0, 0};
    if (s->have_prev)
        for (int r = 0; r < 3; ++r)
            for (int c = 0; c < 3; ++c) jdq[r] += (s->J[3 * r + c] - s->Jprev[3 * r + c]) / dt * s->qd[c];
    double rhs[3];
    for (int i = 0; i < 3; ++i) {
        double acc = tq[i];
        for (int r = 0; r < 3; ++r) acc += s->J[3 * r + i] * (fdev[r] - m * jdq[r]);
        acc -= P.b_visc[i] * s->qd[i];
        if (P.tau_c[i] != 0) acc -= P.tau_c[i] * std::tanh(s->qd[i] / P.coulomb_w);
        rhs[i] = acc;
    }
    double M[3][3];
    for (int r = 0; r < 3; ++r)
        for (int c = 0; c < 3; ++c) {
            double x = 0;
            for (int k2 = 0; k2 < 3; ++k2) x += s->J[3 * k2 + r] * s->J[3 * k2 + c];
            M[r][c] = m * x + (r == c ? P.j_rotor : 0.0);
        }
    // held joints (axes not simulated): qd = 0, the free ones solve the reduced system
    int idx[3], nf = 0;
    for (int i = 0; i < 3; ++i)
        if (P.free_[i]) idx[nf++] = i;
    double a[3][3], b[3];
    for (int r = 0; r < nf; ++r) {
        b[r] = rhs[idx[r]];
        for (int c = 0; c < nf; ++c) a[r][c] = M[idx[r]][idx[c]];
    }
    if (nf) solve(a, b, nf);
    // semi-implicit (symplectic) Euler
    for (int r = 0; r < nf; ++r) s->qd[idx[r]] += dt * b[r];
    for (int i = 0; i < 3; ++i) {
        if (!P.free_[i]) s->qd[i] = 0;
        s->q[i] += dt * s->qd[i];
    }
    std::memcpy(s->Jprev, s->J, sizeof s->J);
    s->have_prev = true;
    s->t += dt;
}

}  // namespace

extern "C" {

void hg_plant_step(hg_plant* s, int n) {
    for (int k = 0; k < n; ++k) {
        // amplifier: first-order current loop toward the (limited) commands, exact for a
        // command held over the step
        for (int i = 0; i < 3; ++i) {
            s->ia[i] += (s->icmd_a[i] - s->ia[i]) * s->alpha;
            s->ib[i] += (s->icmd_b[i] - s->ib[i]) * s->alpha;
        }
        mech_step(s, s->P.dt, s->ia, s->ib);
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
    for (int i = 0; i < 3; ++i) s->q[i] += 1e-6 * s->qd[i];
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
    for (int i = 0; i < 3; ++i) {
        if (!((mask >> i) & 1)) continue;
        const double x = (s->q[i] - P.q_index[i]) / (2 * kPi) * P.lines;
        double na = 0, nb = 0;
        if (P.noise[i] > 0) {
            na = P.noise[i] * s->rng.normal();
            nb = P.noise[i] * s->rng.normal();
        }
        encode_one(P, i, x, na, nb, &a[i], &b[i]);
        const double line = std::floor(x);
        const double mline = line - P.lines * std::floor(line / P.lines);
        idx[i] = (mline == 0.0 && x - line < 0.25) ? 1 : 0;
    }
}

void hg_plant_read(const hg_plant* s, hg_plant_out* o) {
    double th[3], tau[3];
    const Trig kq = trig(s->q);   // (one evaluation for both)
    motor_torque(s, tau, th);
    fill_out(s, kq, tau, th, o);
}

void hg_plant_q(const hg_plant* p, double q[3]) {
    for (int i = 0; i < 3; ++i) q[i] = p->q[i];
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

}  // extern "C"
