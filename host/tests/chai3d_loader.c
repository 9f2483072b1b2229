/* SPDX-License-Identifier: Apache-2.0 */
/* chai3d-loader: opens the shims the way CHAI3D 3.x's Phantom support does on Linux, and
 * renders a wall through them from a separate haptic thread (tb/host_c drives it).
 *
 * The sequence, read from CHAI3D's src/devices/CPhantomDevices.cpp (no code copied):
 *   - dlopen("libHD.so", RTLD_LAZY|RTLD_GLOBAL) must succeed; nothing is used from it;
 *   - dlopen("libhdPhantom.so", RTLD_LAZY|RTLD_GLOBAL), dlsym of 14 names, all required;
 *   - cHapticDeviceHandler: GetNumDevices; the device's constructor: GetNumDevices,
 *     GetWorkspaceRadius, GetType (into a 255-byte buffer);
 *   - open(): Open(id), its result ignored; calibrate(): nothing;
 *   - the application's haptic thread, unpaced: GetPosition, GetRotation, GetButtons,
 *     SetForceAndTorque (forces in N, CHAI3D's frame);
 *   - close(): Close(id), then StopServo().  StartServo is resolved but never called.
 *
 *     chai3d-loader count                  prints "devices N" (N = GetNumDevices)
 *     chai3d-loader wall SECONDS [K B DEPTH_MM]
 *         a horizontal plane DEPTH_MM into the resting handle, free space below (CHAI3D
 *         frame: normal -z): F = n max(0, K d - B v.n) with d = (p0 - p).n pushes the handle
 *         down and the hand holds it. Prints "G,0,x,y,z" for the first position, "R,..." every
 *         100 iterations, and "DONE,iterations,seconds,radius,type".
 * Exit 0, 1 when a call fails, 2 on bad arguments, 3 when a library or symbol is missing. */
#include <dlfcn.h>
#include <math.h>
#include <pthread.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

typedef int (*fn_i_v)(void);
typedef int (*fn_i_i)(int);
typedef int (*fn_i_i3d)(int, double *, double *, double *);
typedef int (*fn_i_i6d)(int, double *, double *, double *, double *, double *, double *);
typedef int (*fn_i_i9d)(int, double *, double *, double *, double *, double *, double *,
                        double *, double *, double *);
typedef int (*fn_i_id)(int, double *);
typedef int (*fn_i_ic)(int, char *);
typedef void (*fn_v_v)(void);

static struct {
    fn_i_v num;
    fn_i_i open, close, buttons;
    fn_i_i3d pos, vel, force, torque;
    fn_i_i9d rot;
    fn_i_i6d force_torque;
    fn_i_id radius;
    fn_i_ic type;
    fn_v_v start, stop;
} P;

static const char *const NAMES[14] = {
    "hdPhantomGetNumDevices", "hdPhantomOpen", "hdPhantomClose", "hdPhantomGetPosition",
    "hdPhantomGetLinearVelocity", "hdPhantomGetRotation", "hdPhantomGetButtons",
    "hdPhantomSetForce", "hdPhantomSetTorque", "hdPhantomSetForceAndTorque",
    "hdPhantomGetWorkspaceRadius", "hdPhantomGetType", "hdPhantomStartServo",
    "hdPhantomStopServo",
};

static int load(void)
{
    void *hd = dlopen("libHD.so", RTLD_LAZY | RTLD_GLOBAL);
    if (!hd) {
        fprintf(stderr, "chai3d-loader: %s\n", dlerror());
        return 3;
    }
    void *so = dlopen("libhdPhantom.so", RTLD_LAZY | RTLD_GLOBAL);
    if (!so) {
        fprintf(stderr, "chai3d-loader: %s\n", dlerror());
        return 3;
    }
    void *sym[14];
    for (int i = 0; i < 14; i++) {
        sym[i] = dlsym(so, NAMES[i]);
        if (!sym[i]) {
            fprintf(stderr, "chai3d-loader: %s missing\n", NAMES[i]);
            return 3;
        }
    }
    /* object pointer -> function pointer through memcpy (ISO C has no direct cast) */
    memcpy(&P.num, &sym[0], sizeof P.num);
    memcpy(&P.open, &sym[1], sizeof P.open);
    memcpy(&P.close, &sym[2], sizeof P.close);
    memcpy(&P.pos, &sym[3], sizeof P.pos);
    memcpy(&P.vel, &sym[4], sizeof P.vel);
    memcpy(&P.rot, &sym[5], sizeof P.rot);
    memcpy(&P.buttons, &sym[6], sizeof P.buttons);
    memcpy(&P.force, &sym[7], sizeof P.force);
    memcpy(&P.torque, &sym[8], sizeof P.torque);
    memcpy(&P.force_torque, &sym[9], sizeof P.force_torque);
    memcpy(&P.radius, &sym[10], sizeof P.radius);
    memcpy(&P.type, &sym[11], sizeof P.type);
    memcpy(&P.start, &sym[12], sizeof P.start);
    memcpy(&P.stop, &sym[13], sizeof P.stop);
    return 0;
}

typedef struct {
    double seconds, k, b, depth;
    long iterations;
    int failed;
    double elapsed;
} haptic_t;

static double now_s(void)
{
    struct timespec t;
    clock_gettime(CLOCK_MONOTONIC, &t);
    return (double)t.tv_sec + 1e-9 * (double)t.tv_nsec;
}

/* The application's haptic thread: unpaced, as CHAI3D examples are. */
static void *haptic(void *arg)
{
    haptic_t *h = arg;
    double p[3], rot[9], v[3];
    if (P.pos(0, &p[0], &p[1], &p[2]) != 0) {
        h->failed = 1;
        return NULL;
    }
    printf("G,0,%.17g,%.17g,%.17g\n", p[0], p[1], p[2]);
    const double plane_z = p[2] - h->depth * 1e-3; /* the plane; free space below (-z) */
    const double t0 = now_s();
    while (now_s() - t0 < h->seconds) {
        if (P.pos(0, &p[0], &p[1], &p[2]) != 0 || P.vel(0, &v[0], &v[1], &v[2]) != 0
            || P.rot(0, &rot[0], &rot[1], &rot[2], &rot[3], &rot[4], &rot[5], &rot[6], &rot[7],
                     &rot[8]) != 0
            || P.buttons(0) != 0) {
            h->failed = 1;
            break;
        }
        const double d = p[2] - plane_z; /* depth: (p0 - p).n with n = (0, 0, -1) */
        double f[3] = { 0.0, 0.0, d > 0.0 ? -fmax(0.0, h->k * d + h->b * v[2]) : 0.0 };
        double t[3] = { 0.0, 0.0, 0.0 };
        if (P.force_torque(0, &f[0], &f[1], &f[2], &t[0], &t[1], &t[2]) != 0) {
            h->failed = 1;
            break;
        }
        if (h->iterations % 100 == 0)
            printf("R,%ld,%.17g,%.17g,%.17g,%.17g\n", h->iterations, p[0], p[1], p[2], f[2]);
        h->iterations++;
    }
    h->elapsed = now_s() - t0;
    return NULL;
}

int main(int argc, char **argv)
{
    if (argc < 2 || (strcmp(argv[1], "count") && strcmp(argv[1], "wall"))) {
        fprintf(stderr, "usage: chai3d-loader count | wall SECONDS [K B DEPTH_MM]\n");
        return 2;
    }
    const int l = load();
    if (l)
        return l;
    const int n = P.num(); /* cHapticDeviceHandler */
    printf("devices %d\n", n);
    fflush(stdout);
    if (!strcmp(argv[1], "count"))
        return 0;
    haptic_t h = { argc > 2 ? atof(argv[2]) : 1.0, argc > 3 ? atof(argv[3]) : 1000.0,
                   argc > 4 ? atof(argv[4]) : 5.0, argc > 5 ? atof(argv[5]) : 1.0, 0, 0, 0.0 };
    if (n < 1 || !(h.seconds > 0))
        return 1;
    /* the device's constructor */
    double radius = 0.10;
    char type[255] = "";
    if (P.num() < 1)
        return 1;
    P.radius(0, &radius);
    P.type(0, type);
    P.open(0); /* open(): the result is ignored; calibrate() does nothing */
    pthread_t th;
    if (pthread_create(&th, NULL, haptic, &h) != 0)
        return 1;
    pthread_join(th, NULL);
    const int c = P.close(0); /* close(): Close, then StopServo */
    P.stop();
    printf("DONE,%ld,%.3f,%.6g,%s\n", h.iterations, h.elapsed, radius, type);
    return h.failed || c != 0 ? 1 : 0;
}
