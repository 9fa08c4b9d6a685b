#include "server/base/posix_io.hpp"

#include <gtest/gtest.h>

#include <cerrno>
#include <string>

namespace soilvol::server {
namespace {

// Issue 12 #10: write errors showed the absolute data path and the server's pid. The message a
// client sees names the entry inside the data directory only; the code keeps its meaning.
TEST(ErrnoStatusTest, NamesTheEntryNotTheHostPathOrPid) {
    const absl::Status full =
        ErrnoStatus(ENOSPC, "cannot write", "/srv/secret/data/containers/.bucket-7.48213.k2f9.tmp");
    EXPECT_EQ(full.code(), absl::StatusCode::kUnavailable);
    EXPECT_EQ(full.message(),
              "data directory: cannot write containers/a temporary file for bucket-7: No space "
              "left on device");
    const absl::Status denied =
        ErrnoStatus(EACCES, "cannot open", "/srv/secret/data/calibrations/rig.entry");
    EXPECT_EQ(denied.code(), absl::StatusCode::kInternal);
    EXPECT_EQ(denied.message(),
              "data directory: cannot open calibrations/rig.entry: Permission denied");
    const std::string bare(ErrnoStatus(EIO, "cannot fsync", "data").message());
    EXPECT_EQ(bare, "data directory: cannot fsync data: Input/output error");
    for (const std::string& message :
         {std::string(full.message()), std::string(denied.message())}) {
        EXPECT_EQ(message.find("/srv"), std::string::npos);
        EXPECT_EQ(message.find("48213"), std::string::npos);
    }
}

}  // namespace
}  // namespace soilvol::server
