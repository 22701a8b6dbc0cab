/* Publishes 2 s of a robot standing level and facing east: a 100 Hz IMU (sensor
 * 0), a 10 Hz magnetometer (sensor 2: Munich's field in the body's axes), a
 * 10 Hz twist (sensor 4: standing still), a 10 Hz barometer (sensor 5) and
 * 10 Hz poses (sensor 6: standing still in a map turned against the world);
 * then a twist with a NaN in its covariance, which the C API must refuse, and a
 * pose whose quaternion is not of unit norm, which fusiond must refuse.
 * Usage: robot NAMESPACE */
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <string.h>
#include <time.h>
#include "fusion_client.h"

static int fail(const char *what) {
    fprintf(stderr, "%s: %s\n", what, fusion_last_error());
    return 1;
}

int main(int argc, char **argv) {
    if (argc != 2) {
        fprintf(stderr, "usage: robot NAMESPACE\n");
        return 2;
    }
    FusionClient *client;
    FusionPublisher *imu, *mag, *twist, *baro, *pose;
    if (fusion_client_connect(argv[1], NULL, &client) != FUSION_OK) return fail("connect");
    if (fusion_publisher_new(client, FUSION_KIND_IMU, 0, &imu) != FUSION_OK
        || fusion_publisher_new(client, FUSION_KIND_MAGNETOMETER, 2, &mag) != FUSION_OK
        || fusion_publisher_new(client, FUSION_KIND_TWIST, 4, &twist) != FUSION_OK
        || fusion_publisher_new(client, FUSION_KIND_BAROMETER, 5, &baro) != FUSION_OK
        || fusion_publisher_new(client, FUSION_KIND_POSE, 6, &pose) != FUSION_OK)
        return fail("publisher");
    const double pi = 3.14159265358979323846;
    const double d = 3.5 * pi / 180.0, i = 64.5 * pi / 180.0, b = 48.5;
    FusionMagnetometerSample m;
    memset(&m, 0, sizeof m);
    m.field_ut[0] = b * cos(i) * sin(d); /* the body faces east: body = (east, north, up) */
    m.field_ut[1] = b * cos(i) * cos(d);
    m.field_ut[2] = -b * sin(i);
    m.cov_ut2[0] = m.cov_ut2[4] = m.cov_ut2[8] = 0.25;
    FusionTwistSample w;
    memset(&w, 0, sizeof w);
    for (int k = 0; k < 6; k++) w.cov[k * 7] = k < 3 ? 0.05 * 0.05 : 0.01 * 0.01;
    FusionBarometerSample p;
    memset(&p, 0, sizeof p);
    p.pressure_pa = 95000.0;
    p.var_pa2 = 4.0;
    FusionPoseSample q;
    memset(&q, 0, sizeof q);
    q.position_m[0] = 3.0;
    q.position_m[1] = -1.0;
    q.orientation_wxyz[0] = 0.6; /* turned 106 degrees about up in the map */
    q.orientation_wxyz[3] = 0.8;
    for (int k = 0; k < 6; k++) q.cov[k * 7] = k < 3 ? 0.05 * 0.05 : 0.005 * 0.005;
    FusionImuSample s;
    memset(&s, 0, sizeof s);
    s.accel_mps2[2] = 9.80665;
    uint64_t t0 = fusion_now_ns() - 3000000000ull;
    struct timespec pause = {0, 500000};
    for (int k = 0; k < 200; k++) {
        uint64_t t = t0 + (uint64_t)k * 10000000ull;
        s.header.t_ns = t;
        if (fusion_publish_imu(imu, &s, NULL) != FUSION_OK) return fail("imu");
        if (k % 10 == 3) {
            m.header.t_ns = t;
            if (fusion_publish_magnetometer(mag, &m, NULL) != FUSION_OK) return fail("magnetometer");
        }
        if (k % 10 == 7) {
            w.header.t_ns = t;
            if (fusion_publish_twist(twist, &w, NULL) != FUSION_OK) return fail("twist");
        }
        if (k % 10 == 5) {
            p.header.t_ns = t;
            q.header.t_ns = t;
            /* The one entry point for every kind: the kind, the struct, its size. */
            if (fusion_publish(baro, FUSION_KIND_BAROMETER, &p, sizeof p, NULL) != FUSION_OK) return fail("barometer");
            if (fusion_publish_pose(pose, &q, NULL) != FUSION_OK) return fail("pose");
        }
        nanosleep(&pause, NULL);
    }
    FusionTwistSample bad = w;
    bad.header.t_ns = t0 + 2000000000ull;
    bad.cov[35] = NAN;
    if (fusion_publish_twist(twist, &bad, NULL) != FUSION_ERROR_INVALID_ARGUMENT) {
        fprintf(stderr, "a NaN twist was sent\n");
        return 1;
    }
    printf("refused: %s\n", fusion_last_error());
    FusionPoseSample skewed = q;
    skewed.header.t_ns = t0 + 1995000000ull;
    skewed.orientation_wxyz[0] = 0.7; /* norm 1.063 */
    if (fusion_publish_pose(pose, &skewed, NULL) != FUSION_OK) return fail("skewed pose");
    fusion_publisher_free(pose);
    fusion_publisher_free(baro);
    fusion_publisher_free(twist);
    fusion_publisher_free(mag);
    fusion_publisher_free(imu);
    fusion_client_free(client);
    printf("published 281 samples\n");
    return 0;
}
