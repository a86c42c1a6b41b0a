#include <csignal>

#include "rt/cli/cli.h"

int main(int argc, char** argv) {
    // A file-size limit (RLIMIT_FSIZE) is a write error (EFBIG) that the writer reports and
    // cleans up after, like a full disk, not a kill that leaves temporaries behind.
    std::signal(SIGXFSZ, SIG_IGN);
    return nvs::cli::runCli(argc, argv);
}
