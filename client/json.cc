#include "client/json.h"

#include <google/protobuf/util/json_util.h>

namespace meshsmooth::client {

std::string ToJson(const google::protobuf::Message& message) {
  google::protobuf::util::JsonPrintOptions options;
  options.add_whitespace = true;
  options.preserve_proto_field_names = true;
  std::string json;
  // Fails only for Any fields whose type is unknown; the service's messages have none.
  (void)google::protobuf::util::MessageToJsonString(message, &json, options);
  return json;
}

}  // namespace meshsmooth::client
