// The C header compiles as C++ and links with extern "C" names.
#include "fusion_client.h"

#include <cstdio>

int main(int argc, char **argv) {
    FusionClient *client = nullptr;
    FusionStatus status = fusion_client_connect(argc > 1 ? argv[1] : "fusion", nullptr, &client);
    if (status != FUSION_OK) {
        std::fprintf(stderr, "connect: %s\n", fusion_last_error());
        return 1;
    }
    FusionStateSnapshot snapshot{};
    static_assert(sizeof(snapshot.x) / sizeof(double) == FUSION_MAX_STATE, "state size");
    std::printf("connected; health %s\n", fusion_health_name(FUSION_HEALTH_OK));
    fusion_client_free(client);
    return 0;
}
