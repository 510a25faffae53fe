#include "freeloc/io/submission.h"

#include <zip.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <memory>

#include "freeloc/core/error.h"
#include "freeloc/core/limits.h"
#include "freeloc/io/file_util.h"
#include "freeloc/io/pyparse.h"

namespace freeloc::io {

std::string FormatDouble(double v) {
  FREELOC_CHECK(std::isfinite(v), "cannot write a non-finite number (" << v << ") into a submission");
  if (v == 0) return std::signbit(v) ? "-0.0" : "0.0";
  char buf[40];
  // %.15g already gives the shortest digits whenever 15 or fewer suffice (%g drops trailing zeros); otherwise
  // 16 or 17 digits are needed.
  for (int prec = 15; prec <= 17; ++prec) {
    std::snprintf(buf, sizeof(buf), "%.*g", prec, v);
    if (std::strtod(buf, nullptr) == v) break;
  }
  std::string s(buf);
  if (s.find_first_of(".e") == std::string::npos) s += ".0";
  return s;
}

std::string FormatPoseLine(const SubmissionEntry& e) {
  FREELOC_CHECK(!e.frame.empty() && e.frame.find_first_of(" \t\r\n") == std::string::npos,
                "submission frame name '" << e.frame << "' is empty or contains whitespace");
  FREELOC_CHECK(std::isfinite(e.confidence) && e.confidence >= 0,
                e.frame << ": confidence " << e.confidence << " must be finite and >= 0");
  const auto q = e.query_from_ref.QuaternionWxyz();
  const Eigen::Vector3d& t = e.query_from_ref.translation;
  std::string line = e.frame;
  for (double v : {q[0], q[1], q[2], q[3], t.x(), t.y(), t.z(), e.confidence}) line += " " + FormatDouble(v);
  return line;
}

std::string FormatPoseFile(const std::vector<SubmissionEntry>& entries) {
  std::string out;
  for (const auto& e : entries) out += FormatPoseLine(e) + "\n";
  return out;
}

void WriteZipAtomic(const std::string& path, const std::map<std::string, std::string>& files) {
  WriteFileAtomicWith(path, [&](const std::string& tmp) {
    int err = 0;
    zip_t* z = zip_open(tmp.c_str(), ZIP_CREATE | ZIP_TRUNCATE, &err);
    FREELOC_CHECK(z != nullptr, path << ": cannot create the ZIP (libzip error " << err << ")");
    for (const auto& [name, content] : files) {  // std::map: sorted names
      zip_source_t* src = zip_source_buffer(z, content.data(), content.size(), 0);
      const zip_int64_t idx = src ? zip_file_add(z, name.c_str(), src, ZIP_FL_ENC_UTF_8) : -1;
      if (idx < 0) {
        if (src) zip_source_free(src);
        const std::string msg = zip_strerror(z);
        zip_discard(z);
        FREELOC_THROW(path << ": cannot add " << name << " (" << msg << ")");
      }
      // Fixed DOS timestamp (1980-01-01 00:00) and attributes (regular file, 0644): same poses, same bytes.
      zip_file_set_dostime(z, idx, 0, (0 << 9) | (1 << 5) | 1, 0);
      zip_file_set_external_attributes(z, idx, 0, ZIP_OPSYS_UNIX, (0100644u) << 16);
      zip_set_file_compression(z, idx, ZIP_CM_DEFLATE, 9);
    }
    if (zip_close(z) != 0) {
      const std::string msg = zip_strerror(z);
      zip_discard(z);
      FREELOC_THROW(path << ": writing the ZIP failed (" << msg << ")");
    }
  });
}

void WriteSubmission(const std::string& path, const std::map<std::string, std::vector<SubmissionEntry>>& scenes) {
  std::map<std::string, std::string> files;
  for (const auto& [scene, entries] : scenes) files["pose_" + scene + ".txt"] = FormatPoseFile(entries);
  WriteZipAtomic(path, files);
}

ZipContents ZipContents::Read(const std::string& path) {
  const auto file = MappedFile::Open(path);
  FREELOC_CHECK(file->size() >= 4 && file->data()[0] == 'P' && file->data()[1] == 'K',
                path << ": not a ZIP file; a submission is a ZIP of pose_sNNNNN.txt files");
  zip_error_t zerr;
  zip_error_init(&zerr);
  zip_source_t* src = zip_source_buffer_create(file->data(), file->size(), 0, &zerr);
  FREELOC_CHECK(src, path << ": cannot read as ZIP");
  zip_t* z = zip_open_from_source(src, ZIP_RDONLY, &zerr);
  if (!z) {
    const std::string msg = zip_error_strerror(&zerr);
    zip_source_free(src);
    zip_error_fini(&zerr);
    FREELOC_THROW(path << ": damaged ZIP (" << msg << "); write the submission again");
  }
  zip_error_fini(&zerr);
  std::unique_ptr<zip_t, void (*)(zip_t*)> guard(z, [](zip_t* p) { zip_discard(p); });
  ZipContents c;
  uint64_t total = 0;
  for (zip_int64_t i = 0; i < zip_get_num_entries(z, 0); ++i) {
    const char* n = zip_get_name(z, i, ZIP_FL_ENC_RAW);
    if (!n) continue;
    const std::string name(n);
    zip_stat_t st;
    zip_stat_init(&st);
    FREELOC_CHECK(zip_stat_index(z, i, 0, &st) == 0, path << ": member " << SafeText(name) << " is damaged");
    CheckZipMemberSize(st.size, st.comp_size, st.comp_method == ZIP_CM_STORE, path + ": member " + SafeText(name));
    total += st.size;
    FREELOC_CHECK(total <= static_cast<uint64_t>(Limits().max_submission_bytes),
                  path << ": member " << SafeText(name) << " takes the contents past " << total << " bytes, beyond the "
                       << LimitHint("max_submission_bytes"));
    std::string data(static_cast<size_t>(st.size), '\0');
    if (st.size > 0) {
      zip_file_t* f = zip_fopen_index(z, i, 0);
      FREELOC_CHECK(f, path << ": cannot open member " << name << " (" << zip_strerror(z) << ")");
      const zip_int64_t got = zip_fread(f, data.data(), st.size);
      zip_fclose(f);
      FREELOC_CHECK(got == static_cast<zip_int64_t>(st.size), path << ": member " << name << " is damaged");
    }
    c.names.push_back(name);
    c.files[name] = std::move(data);
  }
  return c;
}

OfficialPoses ParseOfficialPoses(const std::string& text, bool with_confidence) {
  OfficialPoses out;
  const size_t expected = with_confidence ? 9 : 8;
  size_t ln = 0;
  auto drop = [&out, &ln](const std::string& why) {
    if (out.dropped.size() < 1000) out.dropped.push_back("line " + std::to_string(ln) + ": " + why);
    ++out.dropped_count;
  };
  py::ForEachLine(text, [&](const std::string& line) {
    ++ln;
    const auto parts = py::SplitSpace(py::Strip(line));
    if (parts.size() != expected) {
      drop(std::to_string(parts.size()) + " fields, expected " + std::to_string(expected));
      return;
    }
    const std::string& name = parts[0];
    if (name.find('#') != std::string::npos) return;  // comment
    int64_t key;
    if (!py::FrameKey(name, &key)) {
      drop("no frame number in '" + SafeText(name, 80) + "' (expected seq1/frame_00000.jpg)");
      return;
    }
    double v[8] = {0};
    bool ok = true;
    for (size_t k = 1; k < parts.size(); ++k) {
      if (!py::ParseFloat(parts[k], &v[k - 1]) || !std::isfinite(v[k - 1])) ok = false;
    }
    if (!ok) {
      drop("a value is not a finite number");
      return;
    }
    const double qn = std::sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2] + v[3] * v[3]);
    if (qn <= 1e-8) {  // np.isclose(norm, 0)
      drop("quaternion has zero norm");
      return;
    }
    OfficialPose p;
    p.name = name;
    // qinverse (transforms3d 0.4): conjugate / norm → a unit quaternion.
    const double w = v[0] / qn, x = -v[1] / qn, y = -v[2] / qn, z = -v[3] / qn;
    p.q_c2w = {w, x, y, z};
    // t_c2w = −rotate_vector(t, qinv) = −(qinv · (0,t) · conj(qinv)).vec
    const Eigen::Quaterniond qi(w, x, y, z);
    const Eigen::Quaterniond tv(0, v[4], v[5], v[6]);
    const Eigen::Quaterniond r = qi * tv * qi.conjugate();
    p.t_c2w = -Eigen::Vector3d(r.x(), r.y(), r.z());
    p.confidence = with_confidence ? v[7] : 0;
    if (!out.poses.count(key)) out.keys.push_back(key);
    out.poses[key] = p;
  });
  return out;
}

size_t MergeSubmissions(const std::vector<std::string>& inputs, const std::string& out) {
  std::map<std::string, std::string> files, owner;  // entry → bytes, entry → the input it came from
  for (const auto& path : inputs) {
    const ZipContents zip = ZipContents::Read(path);
    for (const auto& name : zip.names) {
      FREELOC_CHECK(name.size() > 9 && name.rfind("pose_", 0) == 0 && name.substr(name.size() - 4) == ".txt",
                    path << ": entry '" << name << "' is not a pose_<scene>.txt file; merge only submission ZIPs");
      FREELOC_CHECK(!owner.count(name), path << ": " << name << " is also in " << owner[name]
                                             << "; the inputs must be disjoint shards of one run");
      owner[name] = path;
      files[name] = zip.files.at(name);
    }
  }
  WriteZipAtomic(out, files);
  return files.size();
}

}  // namespace freeloc::io
