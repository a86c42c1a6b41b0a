#include "rt/cli/cli.h"

int main(int argc, char** argv) {
    return nvs::cli::runCli(argc, argv);
}
