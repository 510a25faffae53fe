#include "freeloc/service/service_fields.h"

namespace freeloc::service {

namespace {

const std::vector<FamilyRow<ServiceOptions>>& Rows() {
  using S = ServiceOptions;
  static const std::vector<FamilyRow<S>> rows = {
      Row("host", "--host", &S::host, "address (or name) to listen on"),
      Row("port", "--port", &S::port, "port (0: any free one, printed)", 0, 65535),
      Row("workers", "--workers", &S::workers, "requests doing work at once", 1, 256),
      Row("max_queue", "--max-queue", &S::max_queue, "requests waiting for a worker; beyond: 503", 0, 100000),
      Row("max_upload_mb", "--max-upload-mb", &S::max_upload_mb, "largest request body, MB; beyond: 413", 1, 4096),
      Row("max_upload_mp", "--max-upload-mp", &S::max_upload_mp,
          "largest photo, in megapixels its header declares; beyond: 400 before decoding", 1, 1000),
      Row("max_anchors", "--max-anchors", &S::max_anchors, "anchors held; beyond: 507", 1, 1000000),
      Row("token", "--token", &S::token, "require 'Authorization: Bearer TOKEN' on /v1 and /metrics"),
      Row("store_dir", "--store", &S::store_dir, "persist anchors to this folder and reload them at start"),
      Row("queue_timeout_s", "--queue-timeout", &S::queue_timeout_s,
          "seconds a request may wait for a worker; beyond: 503", 0.001, 86400),
      Row("header_timeout_s", "--header-timeout", &S::header_timeout_s,
          "seconds a client has to send its request headers; beyond: the connection is closed", 0.1, 3600),
      Row("body_timeout_s", "--body-timeout", &S::body_timeout_s,
          "seconds a client has to send its request body; beyond: the connection is closed", 0.1, 86400),
      Row("max_connections", "--max-connections", &S::max_connections,
          "connections open at once; beyond: 503 and closed", 1, 100000),
  };
  return rows;
}

}  // namespace

const OptionFamily& ServiceFamily() {
  static const OptionFamily family = FamilyOf("service", "freeloc serve flags", Rows());
  return family;
}

void SetServiceField(ServiceOptions* options, const std::string& name, const std::string& text) {
  FindRow(Rows(), "service", name).set(options, text);
}

std::string GetServiceField(const ServiceOptions& options, const std::string& name) {
  return FindRow(Rows(), "service", name).get(options);
}

void ServiceOptions::Validate() const {
  // Every field against its row's range (service_fields.cc), as the flags are checked at parse.
  for (const FamilyField& f : ServiceFamily().fields) CheckFieldText(f, GetServiceField(*this, f.name));
  pipeline.Validate();
}

}  // namespace freeloc::service
