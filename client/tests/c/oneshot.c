/* Publishes one IMU sample as sensor SENSOR with sequence number SEQ and exits
 * at once (a program run by cron or a script). Usage: oneshot NAMESPACE SENSOR SEQ */
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include "fusion_client.h"

int main(int argc, char **argv) {
    if (argc != 4) {
        fprintf(stderr, "usage: oneshot NAMESPACE SENSOR SEQ\n");
        return 2;
    }
    FusionClient *client;
    FusionPublisher *imu;
    if (fusion_client_connect(argv[1], NULL, &client) != FUSION_OK
        || fusion_publisher_new(client, FUSION_KIND_IMU, (uint32_t)atoi(argv[2]), &imu) != FUSION_OK) {
        fprintf(stderr, "fusion: %s\n", fusion_last_error());
        return 1;
    }
    FusionImuSample sample = {.header.t_ns = fusion_now_ns(), .header.seq = (uint64_t)atoll(argv[3]),
                              .accel_mps2 = {0.1, 0.0, 0.0}};
    if (fusion_publish_imu(imu, &sample, NULL) != FUSION_OK) {
        fprintf(stderr, "fusion: %s\n", fusion_last_error());
        return 1;
    }
    fusion_publisher_free(imu);
    fusion_client_free(client);
    return 0;
}
