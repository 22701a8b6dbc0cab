/* The C API refuses bad input with a status and a reason, never a crash.
 * Prints one line per check; exits 0 when every check held. */
#include <math.h>
#include <stdio.h>
#include <string.h>
#include "fusion_client.h"

static int failed = 0;

static void expect(const char *what, FusionStatus got, FusionStatus want) {
    const char *why = got == FUSION_OK ? "" : fusion_last_error();
    printf("%s: %d (%s)\n", what, (int)got, why);
    if (got != want || (want < 0 && strlen(why) == 0)) {
        printf("  expected %d with a reason\n", (int)want);
        failed = 1;
    }
}

int main(int argc, char **argv) {
    const char *unknown = argc > 1 ? argv[1] : "nobody-here";
    FusionClient *client = NULL;
    FusionPublisher *imu = NULL;
    FusionPublisher *beyond = NULL;
    FusionStateReader *state = NULL;
    FusionStateSnapshot snapshot;
    FusionImuSample sample = {.header.t_ns = fusion_now_ns()};
    FusionPositionSample fix = {.header.t_ns = fusion_now_ns(), .cov_m2 = {1, 0, 0, 0, 1, 0, 0, 0, 1}};

    expect("connect, null namespace", fusion_client_connect(NULL, NULL, &client), FUSION_ERROR_NULL);
    expect("connect, null out", fusion_client_connect(unknown, NULL, NULL), FUSION_ERROR_NULL);
    expect("connect, path-like namespace", fusion_client_connect("a/b", NULL, &client), FUSION_ERROR_INVALID_ARGUMENT);
    expect("connect, bad domain", fusion_client_connect(unknown, "no/such", &client), FUSION_ERROR_INVALID_ARGUMENT);
    expect("connect, unknown namespace", fusion_client_connect(unknown, NULL, &client), FUSION_OK);
    expect("state reader, no fusiond", fusion_state_reader_new(client, &state), FUSION_ERROR_NOT_RUNNING);
    expect("state reader, null client", fusion_state_reader_new(NULL, &state), FUSION_ERROR_NULL);
    expect("publisher, unknown kind", fusion_publisher_new(client, 99, 0, &imu), FUSION_ERROR_INVALID_ARGUMENT);
    expect("publisher, null out", fusion_publisher_new(client, FUSION_KIND_IMU, 0, NULL), FUSION_ERROR_NULL);
    expect("publisher", fusion_publisher_new(client, FUSION_KIND_IMU, 0, &imu), FUSION_OK);
    expect("publish, null sample", fusion_publish_imu(imu, NULL, NULL), FUSION_ERROR_NULL);
    expect("publish, null publisher", fusion_publish_imu(NULL, &sample, NULL), FUSION_ERROR_NULL);
    expect("publish, wrong kind", fusion_publish_position(imu, &fix, NULL), FUSION_ERROR_WRONG_KIND);
    sample.gyro_radps[2] = NAN;
    expect("publish, NaN", fusion_publish_imu(imu, &sample, NULL), FUSION_ERROR_INVALID_ARGUMENT);
    sample.gyro_radps[2] = 0.0;
    size_t reached = 7;
    expect("publish, no fusiond", fusion_publish_imu(imu, &sample, &reached), FUSION_OK);
    if (reached != 0) {
        printf("  reached %zu readers, expected 0\n", reached);
        failed = 1;
    }
    /* The generic entry point checks the kind, the size and the publisher's kind. */
    expect("publish any, no such kind", fusion_publish(imu, FUSION_KIND_COUNT + 1, &sample, sizeof sample, NULL),
           FUSION_ERROR_INVALID_ARGUMENT);
    expect("publish any, kind 0", fusion_publish(imu, 0, &sample, sizeof sample, NULL), FUSION_ERROR_INVALID_ARGUMENT);
    expect("publish any, short struct", fusion_publish(imu, FUSION_KIND_IMU, &sample, sizeof sample - 8, NULL),
           FUSION_ERROR_INVALID_ARGUMENT);
    expect("publish any, wrong kind", fusion_publish(imu, FUSION_KIND_POSITION, &fix, sizeof fix, NULL),
           FUSION_ERROR_WRONG_KIND);
    expect("publish any, null sample", fusion_publish(imu, FUSION_KIND_IMU, NULL, sizeof sample, NULL),
           FUSION_ERROR_NULL);
    reached = 7;
    expect("publish any", fusion_publish(imu, FUSION_KIND_IMU, &sample, sizeof sample, &reached), FUSION_OK);
    if (reached != 0) {
        printf("  reached %zu readers, expected 0\n", reached);
        failed = 1;
    }
    expect("publisher, first kind beyond the count", fusion_publisher_new(client, FUSION_KIND_COUNT + 1, 0, &beyond),
           FUSION_ERROR_INVALID_ARGUMENT);
    expect("latest, null reader", fusion_state_latest(NULL, &snapshot), FUSION_ERROR_NULL);
    fusion_publisher_free(imu);
    fusion_publisher_free(NULL);
    fusion_state_reader_free(NULL);
    fusion_client_free(client);
    fusion_client_free(NULL);
    printf("%s\n", failed ? "FAILED" : "all checks held");
    return failed;
}
