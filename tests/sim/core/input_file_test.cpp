// Bounded input files (sim/core/input_file.h): only regular files are read where a file is
// expected — /dev/zero (an endless read before), a FIFO (a read that blocked forever before)
// and a directory are errors naming the path — and a file over the limit is refused.
#include "sim/core/input_file.h"

#include <gtest/gtest.h>
#include <sys/stat.h>
#include <unistd.h>

#include <fstream>
#include <functional>
#include <string>

#include "sim/core/config.h"
#include "sim/core/csv.h"
#include "sim/core/error.h"
#include "tests/sim/core/test_errors.h"

namespace nvs {
namespace {

TEST(InputFile, OnlyRegularFilesAreRead) {
    const std::string fifo = ::testing::TempDir() + "nvs_input_fifo";
    ::unlink(fifo.c_str());
    ASSERT_EQ(::mkfifo(fifo.c_str(), 0600), 0);
    EXPECT_NE(
        nvs::test::setupErrorOf([&] { readInputFile(fifo, 1024, "test input"); }).find("a FIFO"),
        std::string::npos);
    EXPECT_NE(nvs::test::setupErrorOf([&] {
                  ConfigDocument::parseFile(fifo);
              }).find(fifo + ": configuration"),
              std::string::npos);
    ::unlink(fifo.c_str());
    EXPECT_NE(nvs::test::setupErrorOf([] { CsvTable::load("/dev/zero"); }).find("character device"),
              std::string::npos);
    EXPECT_NE(nvs::test::setupErrorOf([] {
                  readInputFile("/tmp", 1024, "test input");
              }).find("a directory"),
              std::string::npos);
    EXPECT_NE(
        nvs::test::setupErrorOf([] { requireRegularFile("/dev/null", "x"); }).find("/dev/null: x:"),
        std::string::npos);
}

TEST(InputFile, LimitAndContent) {
    const std::string path = ::testing::TempDir() + "nvs_input_file.txt";
    std::ofstream(path) << std::string(5000, 'a') << "b";
    EXPECT_EQ(readInputFile(path, 5001, "t").size(), 5001u);
    EXPECT_EQ(readInputFile(path, 5001, "t").back(), 'b');
    EXPECT_NE(nvs::test::setupErrorOf([&] {
                  readInputFile(path, 5000, "t");
              }).find("more than the limit"),
              std::string::npos);
    std::ofstream(path, std::ios::trunc).flush();
    EXPECT_TRUE(readInputFile(path, 10, "t").empty());
    ::unlink(path.c_str());
}

}  // namespace
}  // namespace nvs
