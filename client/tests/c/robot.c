/* Publishes 2 s of a robot standing level and facing east: a 100 Hz IMU (sensor
 * 0), a 10 Hz magnetometer (sensor 2: Munich's field in the body's axes) and a
 * 10 Hz twist (sensor 4: standing still); then a twist with a NaN in its
 * covariance, which the C API must refuse. Usage: robot NAMESPACE */
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
    FusionPublisher *imu, *mag, *twist;
    if (fusion_client_connect(argv[1], NULL, &client) != FUSION_OK) return fail("connect");
    if (fusion_publisher_new(client, FUSION_KIND_IMU, 0, &imu) != FUSION_OK
        || fusion_publisher_new(client, FUSION_KIND_MAGNETOMETER, 2, &mag) != FUSION_OK
        || fusion_publisher_new(client, FUSION_KIND_TWIST, 4, &twist) != FUSION_OK)
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
    fusion_publisher_free(twist);
    fusion_publisher_free(mag);
    fusion_publisher_free(imu);
    fusion_client_free(client);
    printf("published 240 samples\n");
    return 0;
}
