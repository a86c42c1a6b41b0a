#include "sim/core/csv.h"

#include <gtest/gtest.h>

namespace nvs {
namespace {

TEST(Csv, ReadsCommentsHeaderQuotedFieldsAndLineNumbers) {
    const CsvTable t = CsvTable::parse(
        "# title\n# source: somewhere, 1999\n\nwl_nm,v_rel,note\n500,0.5,\"a, b\"\n"
        "# a comment between rows\n600,0.25,\"say \"\"hi\"\"\"\n",
        "x.csv");
    EXPECT_EQ(t.commentValue("source"), "somewhere, 1999");
    ASSERT_EQ(t.rowCount(), 2u);
    EXPECT_EQ(t.row(0)[2], "a, b");
    EXPECT_EQ(t.row(1)[2], "say \"hi\"");
    EXPECT_EQ(t.rowLoc(1).str(), "x.csv:7");
    EXPECT_EQ(t.number(1, t.column("v_rel")), 0.25);
}

TEST(Csv, ErrorsNameFileAndLine) {
    const CsvTable t = CsvTable::parse("a_nm,b_rel\n1,2\n3,x\n", "e.csv");
    try {
        t.number(1, 1);
        FAIL();
    } catch (const SetupError& e) {
        EXPECT_STREQ(e.what(), "e.csv:3: column 'b_rel': 'x' is not a number");
    }
    EXPECT_THROW(CsvTable::parse("a,b\n1,2,3\n", "f.csv"), SetupError);
    EXPECT_THROW(t.column("c"), SetupError);
    EXPECT_THROW(CsvTable::parse("# only comments\n", "g.csv"), SetupError);
    EXPECT_THROW(CsvTable::parse("a,b\n\"1,2\n", "h.csv"), SetupError);
}

}  // namespace
}  // namespace nvs
