/* Prints the typed accessors (fusion_snapshot_*) of each snapshot in a file of
 * raw FusionStateSnapshot records as JSON lines (the test compares them with the
 * Rust client's). Usage: typed FILE */
#include <stdint.h>
#include <stdio.h>
#include "fusion_client.h"

typedef FusionStatus (*Accessor)(const FusionStateSnapshot *, double *);

static const struct {
    const char *name;
    Accessor read;
    int len;
} ACCESSORS[] = {
    {"position", fusion_snapshot_position, 3},
    {"velocity", fusion_snapshot_velocity, 3},
    {"attitude", fusion_snapshot_attitude, 4},
    {"roll_pitch_yaw", fusion_snapshot_roll_pitch_yaw, 3},
    {"accel_bias", fusion_snapshot_accel_bias, 3},
    {"gyro_bias", fusion_snapshot_gyro_bias, 3},
    {"position_std", fusion_snapshot_position_std, 3},
    {"velocity_std", fusion_snapshot_velocity_std, 3},
    {"attitude_std", fusion_snapshot_attitude_std, 3},
    {"roll_pitch_yaw_std", fusion_snapshot_roll_pitch_yaw_std, 3},
    {"accel_bias_std", fusion_snapshot_accel_bias_std, 3},
    {"gyro_bias_std", fusion_snapshot_gyro_bias_std, 3},
    {"odometry_scale", fusion_snapshot_odometry_scale, 2},
    {"baro_bias", fusion_snapshot_baro_bias, 2},
    {"pose_frame", fusion_snapshot_pose_frame, 8},
};

int main(int argc, char **argv) {
    FILE *f = argc > 1 ? fopen(argv[1], "rb") : NULL;
    if (f == NULL) {
        fprintf(stderr, "usage: typed FILE\n");
        return 2;
    }
    FusionStateSnapshot s;
    double out[4];
    while (fread(&s, sizeof s, 1, f) == 1) {
        printf("{");
        for (size_t a = 0; a < sizeof ACCESSORS / sizeof ACCESSORS[0]; a++) {
            FusionStatus status = ACCESSORS[a].read(&s, out);
            printf("%s\"%s\": ", a ? ", " : "", ACCESSORS[a].name);
            if (status == FUSION_NOT_IN_MODEL) {
                printf("null");
            } else if (status == FUSION_OK) {
                for (int i = 0; i < ACCESSORS[a].len; i++) {
                    printf("%s%.17g", i ? ", " : "[", out[i]);
                }
                printf("]");
            } else {
                fprintf(stderr, "%s: status %d: %s\n", ACCESSORS[a].name, (int)status, fusion_last_error());
                return 1;
            }
        }
        /* The refusals by reason name, the reasons with a count. */
        printf(", \"rejections\": {");
        int first = 1;
        for (uint32_t code = 1; code <= FUSION_REJECTION_COUNT; code++) {
            if (s.rejections[code] > 0) {
                printf("%s\"%s\": %llu", first ? "" : ", ", fusion_rejection_name(code),
                       (unsigned long long)s.rejections[code]);
                first = 0;
            }
        }
        printf("}}\n");
    }
    /* A null snapshot or output is refused, with a reason. */
    if (fusion_snapshot_position(NULL, out) != FUSION_ERROR_NULL || fusion_snapshot_position(&s, NULL) != FUSION_ERROR_NULL) {
        fprintf(stderr, "null pointers were not refused\n");
        return 1;
    }
    fclose(f);
    return 0;
}
