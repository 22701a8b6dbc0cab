#include <stdio.h>
#include "fusion_client.h"

/* A namespace and an IMU id of its own: beside a live vehicle it must not publish
 * as one of its sensors. Give it the namespace of a fusiond run to try it. */

int main(int argc, char **argv) {
    FusionClient *client; FusionPublisher *imu; FusionStateReader *state; FusionStateSnapshot s;
    if (fusion_client_connect(argc > 1 ? argv[1] : "fusion-example", NULL, &client) != FUSION_OK
        || fusion_publisher_new(client, FUSION_KIND_IMU, 99, &imu) != FUSION_OK
        || fusion_state_reader_new(client, &state) != FUSION_OK)
        return fprintf(stderr, "fusion: %s\n", fusion_last_error()), 1;
    FusionImuSample sample = {.header.t_ns = fusion_now_ns(), .accel_mps2 = {0.1, 0.0, 0.0}};
    if (fusion_publish_imu(imu, &sample, NULL) != FUSION_OK || fusion_state_wait_next(state, 1000000000, &s) != FUSION_OK)
        return fprintf(stderr, "fusion: no snapshot %s\n", fusion_last_error()), 1;
    printf("t_ns %llu x %.17g %.17g %.17g health %s\n", (unsigned long long)s.t_ns, s.x[0], s.x[1], s.x[2], fusion_health_name(s.health));
    fusion_state_reader_free(state); fusion_publisher_free(imu); fusion_client_free(client);
    return 0;
}
