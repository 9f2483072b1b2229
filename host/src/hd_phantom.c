/* SPDX-License-Identifier: Apache-2.0 */
/* libhdPhantom.so: hapgate as a PHANTOM device for unmodified CHAI3D 3.x applications on Linux
 * (docs/native-host.md). CHAI3D's Phantom support checks that libHD.so loads, then resolves
 * these 14 plain C functions from libhdPhantom.so. Written against the interface's documented
 * calling sequence; no CHAI3D code is used.
 *
 * Frames: CHAI3D's x toward the operator, y to the right, z up; the device's +y is up (gravity
 * along -y) and the operator sits on its -z side. With c the workspace box's centre:
 *     x_c = -(z_d - c_z),  y_c = -(x_d - c_x),  z_c = y_d - c_y      (positions, velocities)
 *     F_dx = -F_cy,        F_dy = F_cz,         F_dz = -F_cx         (forces)
 * The port is the environment variable HAPGATE_PORT (HAPGATE_BAUD, HAPGATE_TIMEOUT_S and
 * HAPGATE_TTL_MS are optional; HAPGATE_LOG=FILE writes what crossed the link, for checks).
 *
 * Pacing: CHAI3D's haptic thread calls GetPosition, GetRotation, GetButtons and
 * SetForceAndTorque in a loop that does not pace itself. Each SetForce* sends one FORCE and
 * then waits for the next streamed state, so the loop runs at the stream rate (what the link
 * carries, at most the servo rate) and never spins. CHAI3D never calls hdPhantomStartServo:
 * Open starts the stream itself. A killed application never calls Close: each force lasts
 * its TTL and the device's link-silence timeout then switches forces off. */
#include <math.h>
#include <pthread.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "hapgate.h"

#define TYPE_NAME "hapgate 3-DOF"
#define F_SCALE 0.999 /* the device refuses a force longer than f_max */

static pthread_mutex_t g_mu = PTHREAD_MUTEX_INITIALIZER;
static hg_dev_t *g_dev;      /* open from the first successful probe until Close */
static hg_dev_info_t g_info;
static double g_c[3];        /* the workspace box's centre, device frame */
static int g_live;           /* the stream runs and forces are enabled */
static unsigned g_ttl_ms;
static double g_timeout_s;
static uint32_t g_answered;  /* seq of the newest state handed to the application */
static hg_dev_state_t g_given; /* the state GetPosition handed out last */
static uint32_t g_paced;     /* seq of the state that released the last SetForce */
static FILE *g_log;
static int g_warned;

/* The 14 entry points, declared as CHAI3D's extras/hdPhantom/hdPhantom.h has them. */
int hdPhantomGetNumDevices(void);
int hdPhantomOpen(int a_deviceID);
int hdPhantomClose(int a_deviceID);
int hdPhantomGetPosition(int a_deviceID, double *a_posX, double *a_posY, double *a_posZ);
int hdPhantomGetLinearVelocity(int a_deviceID, double *a_velX, double *a_velY, double *a_velZ);
int hdPhantomGetRotation(int a_deviceID, double *a_rot00, double *a_rot01, double *a_rot02,
                         double *a_rot10, double *a_rot11, double *a_rot12, double *a_rot20,
                         double *a_rot21, double *a_rot22);
int hdPhantomGetButtons(int a_deviceID);
int hdPhantomSetForce(int a_deviceID, double *a_forceX, double *a_forceY, double *a_forceZ);
int hdPhantomSetTorque(int a_deviceID, double *a_torqueX, double *a_torqueY, double *a_torqueZ);
int hdPhantomSetForceAndTorque(int a_deviceID, double *a_forceX, double *a_forceY,
                               double *a_forceZ, double *a_torqueX, double *a_torqueY,
                               double *a_torqueZ);
int hdPhantomGetWorkspaceRadius(int a_deviceID, double *a_workspaceRadius);
int hdPhantomGetType(int a_deviceID, char *a_typeName);
void hdPhantomStartServo(void);
void hdPhantomStopServo(void);

static double env_num(const char *name, double dflt, double lo, double hi)
{
    const char *s = getenv(name);
    char *end = NULL;
    const double v = s && *s ? strtod(s, &end) : dflt;
    if (s && *s && (end == s || *end != '\0' || !(v >= lo && v <= hi))) {
        fprintf(stderr, "hapgate: %s=%s: expected a number in [%g, %g]; using %g\n", name, s,
                lo, hi, dflt);
        return dflt;
    }
    return v;
}

static void to_chai(const double d[3], const double c[3], double out[3])
{
    out[0] = -(d[2] - c[2]);
    out[1] = -(d[0] - c[0]);
    out[2] = d[1] - c[1];
}

static void force_to_device(double fx, double fy, double fz, double out[3])
{
    out[0] = -fy;
    out[1] = fz;
    out[2] = -fx;
}

static void log_push(const hg_dev_state_t *s, void *user)
{
    (void)user;
    fprintf(g_log, "P,%lu,%.9g,%.9g,%.9g,%.9g,%.9g,%.9g,%.9g,%.9g,%.9g,%u,%u,%u\n",
            (unsigned long)s->seq, s->p[0], s->p[1], s->p[2], s->v[0], s->v[1], s->v[2],
            s->f[0], s->f[1], s->f[2], (unsigned)s->force_counter,
            (unsigned)s->force_latency_ticks, s->flags);
}

/* Open the port named by HAPGATE_PORT (forces off) if it is not open yet. g_mu held. */
static int probe(void)
{
    if (g_dev)
        return 1;
    const char *port = getenv("HAPGATE_PORT");
    if (!port || !*port) {
        if (!g_warned++)
            fprintf(stderr, "hapgate: HAPGATE_PORT is not set: no device\n");
        return 0;
    }
    g_timeout_s = env_num("HAPGATE_TIMEOUT_S", 2.0, 0.01, 600.0);
    const uint32_t baud = (uint32_t)env_num("HAPGATE_BAUD", 1e6, 0.0, 12e6);
    hg_dev_t *d = NULL;
    const int r = hg_open(&d, port, baud, g_timeout_s);
    if (r == HG_OK)
        hg_get_info(d, &g_info);
    if (r != HG_OK || g_info.servo_hz == 0) {
        if (!g_warned++)
            fprintf(stderr, "hapgate: %s: %s: no device\n", port, hg_strerror(r));
        if (r == HG_OK)
            hg_close(d);
        return 0;
    }
    for (int i = 0; i < 3; i++)
        g_c[i] = 0.5 * (g_info.box_lo[i] + g_info.box_hi[i]);
    g_dev = d;
    g_warned = 0;
    return 1;
}

/* The link loop: PC_FORCE scene, forces on, the stream at the highest rate the link carries. */
static int start_link(void)
{
    if (!probe())
        return -1;
    if (g_live)
        return 0;
    const char *log = getenv("HAPGATE_LOG");
    if (log && *log && !g_log) {
        g_log = fopen(log, "w");
        if (g_log)
            hg_set_push_hook(g_dev, log_push, NULL);
        else
            fprintf(stderr, "hapgate: HAPGATE_LOG=%s: cannot write it\n", log);
    }
    g_ttl_ms = (unsigned)env_num("HAPGATE_TTL_MS", 10.0, 1.0, (double)g_info.ttl_max_ms);
    double rate = 0.0;
    hg_dev_state_t s;
    int r = hg_set_scene(g_dev, HG_SCENE_PC_FORCE, NULL, NULL, 0.0, 0.0, 0.0);
    if (r == HG_OK)
        r = hg_enable(g_dev, 1);
    if (r == HG_OK)
        r = hg_stream_start(g_dev, 0.0, &rate);
    if (r == HG_OK)
        r = hg_next_push(g_dev, &s, g_timeout_s);
    if (r != HG_OK) {
        fprintf(stderr, "hapgate: starting the link: %s\n", hg_strerror(r));
        return -1;
    }
    g_answered = g_paced = s.seq;
    g_given = s;
    g_live = 1;
    return 0;
}

static void close_dev(void)
{
    if (g_dev) {
        hg_set_push_hook(g_dev, NULL, NULL);
        hg_close(g_dev);
        g_dev = NULL;
    }
    if (g_log) {
        fclose(g_log);
        g_log = NULL;
    }
    g_live = 0;
}

__attribute__((destructor)) static void unload(void)
{
    pthread_mutex_lock(&g_mu);
    close_dev();
    pthread_mutex_unlock(&g_mu);
}

/* The newest streamed state, for the application. g_mu held. */
static int newest(hg_dev_state_t *s)
{
    if (!g_dev || !g_live)
        return -1;
    int r = hg_latest_push(g_dev, s);
    if (r == HG_E_REFUSED) /* a refused force, already counted by the device: read on */
        r = hg_latest_push(g_dev, s);
    if (r != HG_OK)
        return -1;
    g_answered = s->seq;
    return 0;
}

/* One FORCE, then wait for the next streamed state: the pacing. g_mu held. */
static int send_force(double fx, double fy, double fz)
{
    if (!g_dev || !g_live || !isfinite(fx) || !isfinite(fy) || !isfinite(fz))
        return -1;
    double f[3];
    force_to_device(fx, fy, fz, f);
    const double mag = sqrt(f[0] * f[0] + f[1] * f[1] + f[2] * f[2]);
    if (mag > F_SCALE * g_info.f_max_n)
        for (int i = 0; i < 3; i++)
            f[i] *= F_SCALE * g_info.f_max_n / mag;
    uint16_t ctr = 0;
    int r = hg_set_force(g_dev, f, g_ttl_ms, g_answered, &ctr);
    if (r == HG_E_REFUSED) /* an earlier force was refused; this one still goes */
        r = hg_set_force(g_dev, f, g_ttl_ms, g_answered, &ctr);
    if (r != HG_OK)
        return -1;
    if (g_log)
        fprintf(g_log, "F,%u,%.17g,%.17g,%.17g,%.9g,%.9g,%.9g,%lu\n", (unsigned)ctr, fx, fy, fz,
                (double)(float)f[0], (double)(float)f[1], (double)(float)f[2],
                (unsigned long)g_answered);
    /* a state newer than both the one this force answered and the one that released the
     * last force: one force per state, whether or not GetPosition came in between */
    const uint32_t after = (int32_t)(g_answered - g_paced) > 0 ? g_answered : g_paced;
    hg_dev_state_t s;
    r = hg_wait_push(g_dev, after, &s, g_timeout_s);
    if (r == HG_E_REFUSED)
        r = hg_wait_push(g_dev, after, &s, g_timeout_s);
    if (r != HG_OK)
        return -1;
    g_paced = s.seq;
    return 0;
}

int hdPhantomGetNumDevices(void)
{
    pthread_mutex_lock(&g_mu);
    const int n = probe();
    pthread_mutex_unlock(&g_mu);
    return n;
}

int hdPhantomOpen(int a_deviceID)
{
    if (a_deviceID != 0)
        return -1;
    pthread_mutex_lock(&g_mu);
    const int r = start_link();
    pthread_mutex_unlock(&g_mu);
    return r;
}

int hdPhantomClose(int a_deviceID)
{
    if (a_deviceID != 0)
        return -1;
    pthread_mutex_lock(&g_mu);
    const int was = g_dev != NULL;
    close_dev();
    pthread_mutex_unlock(&g_mu);
    return was ? 0 : -1;
}

int hdPhantomGetPosition(int a_deviceID, double *a_posX, double *a_posY, double *a_posZ)
{
    hg_dev_state_t s;
    if (a_deviceID != 0 || !a_posX || !a_posY || !a_posZ)
        return -1;
    pthread_mutex_lock(&g_mu);
    const int r = newest(&s);
    double p[3];
    if (r == 0) {
        g_given = s;
        to_chai(s.p, g_c, p);
        *a_posX = p[0];
        *a_posY = p[1];
        *a_posZ = p[2];
        if (g_log)
            fprintf(g_log, "G,%lu,%.17g,%.17g,%.17g\n", (unsigned long)s.seq, p[0], p[1], p[2]);
    }
    pthread_mutex_unlock(&g_mu);
    return r;
}

int hdPhantomGetLinearVelocity(int a_deviceID, double *a_velX, double *a_velY, double *a_velZ)
{
    static const double zero[3] = { 0.0, 0.0, 0.0 };
    hg_dev_state_t s;
    if (a_deviceID != 0 || !a_velX || !a_velY || !a_velZ)
        return -1;
    pthread_mutex_lock(&g_mu);
    /* the velocity of the state GetPosition handed out last, so that the two agree */
    const int r = g_dev && g_live && g_given.is_push ? (s = g_given, 0) : newest(&s);
    double v[3];
    if (r == 0) {
        to_chai(s.v, zero, v);
        *a_velX = v[0];
        *a_velY = v[1];
        *a_velZ = v[2];
    }
    pthread_mutex_unlock(&g_mu);
    return r;
}

int hdPhantomGetRotation(int a_deviceID, double *a_rot00, double *a_rot01, double *a_rot02,
                         double *a_rot10, double *a_rot11, double *a_rot12, double *a_rot20,
                         double *a_rot21, double *a_rot22)
{
    double *m[9] = { a_rot00, a_rot01, a_rot02, a_rot10, a_rot11, a_rot12, a_rot20, a_rot21,
                     a_rot22 };
    if (a_deviceID != 0)
        return -1;
    for (int i = 0; i < 9; i++) /* a 3-DOF device: the handle's frame is the identity */
        if (m[i])
            *m[i] = i % 4 == 0 ? 1.0 : 0.0;
    return 0;
}

int hdPhantomGetButtons(int a_deviceID)
{
    return a_deviceID == 0 ? 0 : -1;
}

int hdPhantomSetForce(int a_deviceID, double *a_forceX, double *a_forceY, double *a_forceZ)
{
    if (a_deviceID != 0 || !a_forceX || !a_forceY || !a_forceZ)
        return -1;
    pthread_mutex_lock(&g_mu);
    const int r = send_force(*a_forceX, *a_forceY, *a_forceZ);
    pthread_mutex_unlock(&g_mu);
    return r;
}

int hdPhantomSetTorque(int a_deviceID, double *a_torqueX, double *a_torqueY, double *a_torqueZ)
{
    (void)a_torqueX, (void)a_torqueY, (void)a_torqueZ; /* no actuated rotation */
    return a_deviceID == 0 ? 0 : -1;
}

int hdPhantomSetForceAndTorque(int a_deviceID, double *a_forceX, double *a_forceY,
                               double *a_forceZ, double *a_torqueX, double *a_torqueY,
                               double *a_torqueZ)
{
    (void)a_torqueX, (void)a_torqueY, (void)a_torqueZ;
    return hdPhantomSetForce(a_deviceID, a_forceX, a_forceY, a_forceZ);
}

int hdPhantomGetWorkspaceRadius(int a_deviceID, double *a_workspaceRadius)
{
    if (a_deviceID != 0 || !a_workspaceRadius)
        return -1;
    pthread_mutex_lock(&g_mu);
    const int ok = probe();
    if (ok) { /* the largest sphere about the centre that fits the workspace box */
        double r = INFINITY;
        for (int i = 0; i < 3; i++)
            r = fmin(r, 0.5 * (g_info.box_hi[i] - g_info.box_lo[i]));
        *a_workspaceRadius = r;
    }
    pthread_mutex_unlock(&g_mu);
    return ok ? 0 : -1;
}

int hdPhantomGetType(int a_deviceID, char *a_typeName)
{
    if (a_deviceID != 0 || !a_typeName)
        return -1;
    memcpy(a_typeName, TYPE_NAME, sizeof TYPE_NAME); /* CHAI3D passes 255 bytes */
    return 0;
}

void hdPhantomStartServo(void)
{
    pthread_mutex_lock(&g_mu);
    if (g_dev)
        start_link();
    pthread_mutex_unlock(&g_mu);
}

void hdPhantomStopServo(void)
{
    pthread_mutex_lock(&g_mu);
    close_dev();
    pthread_mutex_unlock(&g_mu);
}
