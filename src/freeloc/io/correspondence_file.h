// Correspondence files (docs/formats.md): one `x_ref y_ref x_query y_query` row per line, pixels of each frame's
// original image; blank lines and `#` comments are skipped. Written with each number in its shortest exact decimal
// form, so a file read back gives the same doubles (what `freeloc pose` needs to reproduce a run bit for bit).
#pragma once

#include <Eigen/Core>
#include <string>
#include <vector>

namespace freeloc::io {

// Throws freeloc::Error naming the file and line (not a number, not 4 fields, non-finite).
std::vector<Eigen::Vector4d> ReadCorrespondenceFile(const std::string& path);
// Atomic write.
void WriteCorrespondenceFile(const std::string& path, const std::vector<Eigen::Vector4d>& rows);

}  // namespace freeloc::io
