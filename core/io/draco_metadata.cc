// The names Draco files give their generic attributes: an attribute metadata entry "name".
#include <algorithm>
#include <memory>
#include <utility>

#include "core/io/draco_convert.h"
#include "draco/metadata/geometry_metadata.h"

namespace meshsmooth {

bool AttributeName(const draco::Mesh& dm, int32_t id, std::string* name) {
  const draco::AttributeMetadata* md = dm.GetAttributeMetadataByAttributeId(id);
  return md != nullptr && md->GetEntryString("name", name);
}

int NamedAttributeId(const draco::Mesh& dm, std::string_view name) {
  for (int32_t i = 0; i < dm.num_attributes(); ++i) {
    std::string value;
    if (AttributeName(dm, i, &value) && value == name) return i;
  }
  return -1;
}

void NameAttribute(draco::Mesh& dm, int id, const std::string& name) {
  auto metadata = std::make_unique<draco::AttributeMetadata>();
  metadata->AddEntryString("name", name);
  dm.AddAttributeMetadata(id, std::move(metadata));
}

uint32_t UnusedAttributeUniqueId(const draco::Mesh& dm) {
  uint32_t fresh_id = 0;
  for (int32_t i = 0; i < dm.num_attributes(); ++i) fresh_id = std::max(fresh_id, dm.attribute(i)->unique_id() + 1);
  if (const draco::GeometryMetadata* md = dm.GetMetadata()) {
    for (const auto& am : md->attribute_metadatas()) {
      fresh_id = std::max(fresh_id, static_cast<uint32_t>(am->att_unique_id()) + 1);
    }
  }
  return fresh_id;
}

}  // namespace meshsmooth
