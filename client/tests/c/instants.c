/* Publishes 100 instants of two IMUs averaged (sensors 0 and 1, 100 Hz) and
 * reads the snapshots: one per instant (the first has two: nothing to wait for
 * yet), named after whichever sample completed it; then an instant IMU 1
 * misses, whose snapshot names IMU 0's sample and comes after fusiond's
 * bounded wait, WAIT_NS.
 *
 * Each instant is published once the one before is complete in fusiond: the
 * first once both of its samples have their snapshots (a new publisher's
 * first sample can reach fusiond after the samples sent behind it), every
 * later one once its snapshot came. A snapshot that went out at the bounded
 * wait (this process descheduled for that long between an instant's two
 * publishes) is counted apart: it is the wait doing its work.
 * Usage: instants NAMESPACE WAIT_NS */
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include "fusion_client.h"

#define INSTANTS 100

static int fail(const char *what) {
    fprintf(stderr, "%s: %s\n", what, fusion_last_error());
    return 1;
}

static FusionStateReader *reader;
static unsigned per_instant[INSTANTS + 1];
static uint64_t wait_ns;
static unsigned waited_out;

/* Reads snapshots until the first IMU one of instant `seq` (of sensor `sensor`'s
 * sample, any sensor's for -1), for at most `timeout_ns`, counting every IMU
 * snapshot read by its instant. 0: found. */
static int await_snapshot(uint64_t seq, int sensor, uint64_t timeout_ns, FusionStateSnapshot *s) {
    uint64_t deadline = fusion_now_ns() + timeout_ns;
    while (fusion_now_ns() < deadline) {
        if (fusion_state_wait_next(reader, 50000000ull, s) != FUSION_OK || s->input_kind != FUSION_KIND_IMU) continue;
        if (s->input_seq < INSTANTS && s->input_sensor == 0 && s->publish_ns - s->input_received_ns >= wait_ns)
            waited_out++;
        else if (s->input_seq <= INSTANTS)
            per_instant[s->input_seq]++;
        if (s->input_seq == seq && (sensor < 0 || s->input_sensor == (uint32_t)sensor)) return 0;
    }
    return 1;
}

int main(int argc, char **argv) {
    if (argc != 3) {
        fprintf(stderr, "usage: instants NAMESPACE WAIT_NS\n");
        return 2;
    }
    wait_ns = strtoull(argv[2], NULL, 10);
    FusionClient *client;
    FusionPublisher *first, *last;
    if (fusion_client_connect(argv[1], NULL, &client) != FUSION_OK) return fail("connect");
    if (fusion_publisher_new(client, FUSION_KIND_IMU, 0, &first) != FUSION_OK
        || fusion_publisher_new(client, FUSION_KIND_IMU, 1, &last) != FUSION_OK)
        return fail("publisher");
    if (fusion_state_reader_new(client, &reader) != FUSION_OK) return fail("reader");
    struct timespec connect = {0, 200000000};
    nanosleep(&connect, NULL); /* fusiond connects to the new publishers */
    FusionImuSample s;
    memset(&s, 0, sizeof s);
    s.accel_mps2[0] = 0.1;
    FusionStateSnapshot snap;
    uint64_t t0 = fusion_now_ns() - 2000000000ull;
    /* Each publisher numbers its samples from 0: sample k of both IMUs has seq k. */
    for (uint64_t k = 0; k < INSTANTS; k++) {
        s.header.t_ns = t0 + k * 10000000ull;
        if (fusion_publish_imu(first, &s, NULL) != FUSION_OK || fusion_publish_imu(last, &s, NULL) != FUSION_OK)
            return fail("imu");
        if (await_snapshot(k, k == 0 ? 1 : -1, 2000000000ull, &snap)) {
            fprintf(stderr, "no snapshot of instant %llu\n", (unsigned long long)k);
            return 1;
        }
    }
    /* Whatever else came (a second snapshot of an instant would be here). */
    await_snapshot(UINT64_MAX, -1, 200000000ull, &snap);
    unsigned least = per_instant[1], most = per_instant[1];
    for (int k = 1; k < INSTANTS; k++) {
        if (per_instant[k] < least) least = per_instant[k];
        if (per_instant[k] > most) most = per_instant[k];
    }
    printf("100 instants: snapshots of the first %u, of each later one %u to %u (and %u at the wait)\n", per_instant[0],
           least, most, waited_out);
    s.header.t_ns = t0 + INSTANTS * 10000000ull;
    if (fusion_publish_imu(first, &s, NULL) != FUSION_OK) return fail("imu");
    if (await_snapshot(INSTANTS, 0, 2000000000ull, &snap)) {
        fprintf(stderr, "no snapshot of instant %d\n", INSTANTS);
        return 1;
    }
    printf("an instant IMU 1 missed: its snapshot after %.0f us\n",
           (double)(snap.publish_ns - snap.input_received_ns) / 1e3);
    fusion_state_reader_free(reader);
    fusion_publisher_free(last);
    fusion_publisher_free(first);
    fusion_client_free(client);
    return 0;
}
