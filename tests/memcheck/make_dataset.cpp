// nvs_memcheck_dataset OUT_DIR: a small generated dataset (64 x 48, no hidden effect) for the
// memcheck test of `nvstim diagnose` (tests/memcheck); written natively, read under valgrind.

#include <cstdio>
#include <exception>

#include "sim/fit/generate.h"

int main(int argc, char** argv) {
    if (argc != 3) {
        std::fprintf(stderr, "usage: nvs_memcheck_dataset CONFIG_DIR OUT_DIR\n");
        return 2;
    }
    try {
        nvs::fit::GenSpec s;
        s.seed = 1;
        s.width = 64;
        s.height = 48;
        nvs::fit::writeDataset(nvs::fit::generate(s, argv[1]).data, argv[2]);
    } catch (const std::exception& e) {
        std::fprintf(stderr, "nvs_memcheck_dataset: %s\n", e.what());
        return 1;
    }
    return 0;
}
