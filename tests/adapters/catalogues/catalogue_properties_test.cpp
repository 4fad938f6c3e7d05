// Properties every family's catalogue must have (decision 009): unique ids and names, Find by
// name and by id text round-trips, defaults inside ranges, Validate refuses out-of-range values
// naming the parameter and the limit; plus each family's own naming and open address space.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <limits>
#include <memory>
#include <ostream>
#include <set>
#include <string>

#include "absl/strings/str_format.h"
#include "adapters/core/parameter_catalogue.h"
#include "adapters/linmot/devicenet/factory.h"
#include "adapters/linmot/linudp/factory.h"
#include "adapters/stober/factory.h"
#include "adapters/trinamic/factory.h"

namespace drivegw {
namespace {

using ::testing::HasSubstr;

struct Family {
  const char* name;
  std::shared_ptr<const ParameterCatalogue> (*catalogue)();
  const char* id_format;  // how the family's id text looks
};

void PrintTo(const Family& f, std::ostream* os) { *os << f.name; }

const Family kFamilies[] = {
    {"trinamic", &trinamic::TrinamicParameterCatalogue, "0x%04X"},
    {"stober", &stober::StoberParameterCatalogue, "0x%06X"},
    {"linmot", &linmot::linudp::LinMotParameterCatalogue, "0x%04X"},
    {"linmot-devicenet", &linmot::devicenet::LinMotDevicenetParameterCatalogue, "0x%02X"},
};

class CatalogueTest : public ::testing::TestWithParam<Family> {
 protected:
  std::shared_ptr<const ParameterCatalogue> cat_ = GetParam().catalogue();
};

TEST_P(CatalogueTest, FamilyNameAndSingleInstance) {
  EXPECT_EQ(cat_->family(), GetParam().name);
  EXPECT_EQ(cat_.get(), GetParam().catalogue().get());
  EXPECT_GE(cat_->Definitions().size(), 10u);
}

TEST_P(CatalogueTest, IdsAndNamesUnique) {
  std::set<uint32_t> ids;
  std::set<std::string> names;
  for (const ParameterDefinition& d : cat_->Definitions()) {
    EXPECT_TRUE(ids.insert(d.id).second) << d.name << " id " << d.id;
    EXPECT_TRUE(names.insert(d.name).second) << d.name;
    EXPECT_FALSE(d.name.empty());
    EXPECT_FALSE(d.type.empty()) << d.name;
    EXPECT_FALSE(d.description.empty()) << d.name;
    EXPECT_LE(d.min, d.max) << d.name;
  }
}

TEST_P(CatalogueTest, FindByNameAndByIdTextRoundTrips) {
  for (const ParameterDefinition& d : cat_->Definitions()) {
    auto by_name = cat_->Find(d.name);
    ASSERT_TRUE(by_name.ok()) << by_name.status();
    EXPECT_EQ(by_name->id, d.id);
    EXPECT_EQ(by_name->name, d.name);
    const std::string id_text = absl::StrFormat(GetParam().id_format, d.id);
    auto by_id = cat_->Find(id_text);
    ASSERT_TRUE(by_id.ok()) << id_text << ": " << by_id.status();
    EXPECT_EQ(by_id->id, d.id) << id_text;
    EXPECT_EQ(by_id->name, d.name) << id_text;
    EXPECT_EQ(by_id->min, d.min);
    EXPECT_EQ(by_id->max, d.max);
  }
}

TEST_P(CatalogueTest, DefaultsInsideRangesAndValid) {
  for (const ParameterDefinition& d : cat_->Definitions()) {
    if (!d.default_value) continue;
    EXPECT_GE(*d.default_value, d.min) << d.name;
    EXPECT_LE(*d.default_value, d.max) << d.name;
    EXPECT_TRUE(cat_->Validate(d, *d.default_value).ok()) << d.name;
  }
}

TEST_P(CatalogueTest, ValidateRefusesOutOfRangeNamingParameterAndLimit) {
  int writable = 0;
  for (const ParameterDefinition& d : cat_->Definitions()) {
    if (!d.writable) {
      const absl::Status s = cat_->Validate(d, d.min);
      EXPECT_EQ(s.code(), absl::StatusCode::kInvalidArgument) << d.name;
      EXPECT_THAT(s.message(), HasSubstr(d.name));
      continue;
    }
    ++writable;
    EXPECT_TRUE(cat_->Validate(d, d.min).ok()) << d.name << " " << d.min;
    EXPECT_TRUE(cat_->Validate(d, d.max).ok()) << d.name << " " << d.max;
    if (d.max < std::numeric_limits<int64_t>::max()) {
      const absl::Status above = cat_->Validate(d, d.max + 1);
      EXPECT_EQ(above.code(), absl::StatusCode::kInvalidArgument) << d.name;
      EXPECT_THAT(above.message(), HasSubstr(d.name));
      EXPECT_THAT(above.message(), HasSubstr(std::to_string(d.max)));
    }
    if (d.min > std::numeric_limits<int64_t>::min()) {
      const absl::Status below = cat_->Validate(d, d.min - 1);
      EXPECT_EQ(below.code(), absl::StatusCode::kInvalidArgument) << d.name;
      EXPECT_THAT(below.message(), HasSubstr(std::to_string(d.min)));
    }
  }
  EXPECT_GT(writable, 0);
}

TEST_P(CatalogueTest, UnknownTextIsNotFoundNamingTheFamily) {
  const auto r = cat_->Find("no such parameter");
  EXPECT_EQ(r.status().code(), absl::StatusCode::kNotFound);
  EXPECT_THAT(r.status().message(), HasSubstr(GetParam().name));
  EXPECT_THAT(r.status().message(), HasSubstr("no such parameter"));
}

INSTANTIATE_TEST_SUITE_P(AllFamilies, CatalogueTest, ::testing::ValuesIn(kFamilies),
                         [](const auto& info) {
                           std::string n = info.param.name;
                           for (char& c : n) {
                             if (c == '-') c = '_';
                           }
                           return n;
                         });

// ---- per family

TEST(TrinamicCatalogue, NamesAndIdsOfTheShadowTable) {
  const auto cat = trinamic::TrinamicParameterCatalogue();
  auto vmax = cat->Find("$14.vmax");
  ASSERT_TRUE(vmax.ok()) << vmax.status();
  EXPECT_EQ(vmax->id, 0x1403u);
  EXPECT_EQ(cat->Find("0x1403")->name, "$14.vmax");
  EXPECT_FALSE(vmax->has_stored_value);  // G-24
  EXPECT_EQ(cat->Find("0x9999").status().code(), absl::StatusCode::kNotFound);
}

TEST(StoberCatalogue, NamesAddressesAndOpenSpace) {
  const auto cat = stober::StoberParameterCatalogue();
  auto i10 = cat->Find("I10");
  ASSERT_TRUE(i10.ok()) << i10.status();
  EXPECT_EQ(i10->id, (0x2000u + 8 * 0x200 + 10) << 8);  // I = group 8 (§7.2)
  EXPECT_EQ(i10->unit, "u/s (wire 0.001 u/s)");
  auto a515 = cat->Find("A515");
  ASSERT_TRUE(a515.ok());
  EXPECT_EQ(a515->id, 0x604000u);
  EXPECT_EQ(cat->Find("0x6040:00")->name, "A515");
  EXPECT_EQ(cat->Find("0x604000")->name, "A515");
  EXPECT_EQ(cat->Find("6040h")->name, "A515");
  auto status = cat->Find("A516");
  ASSERT_TRUE(status.ok());
  EXPECT_FALSE(status->writable);
  // Unbound but well-formed: synthesized raw object.
  auto raw = cat->Find("0x2000:01");
  ASSERT_TRUE(raw.ok()) << raw.status();
  EXPECT_EQ(raw->id, 0x200001u);
  EXPECT_EQ(raw->type, "unknown");
  EXPECT_EQ(raw->name, "0x2000:01");
  EXPECT_EQ(cat->Find("0x12345:00").status().code(), absl::StatusCode::kNotFound);
}

TEST(LinMotCatalogue, DocumentedUpidsAndOpenSpace) {
  const auto cat = linmot::linudp::LinMotParameterCatalogue();
  auto v = cat->Find("0x14BE");
  ASSERT_TRUE(v.ok());
  EXPECT_EQ(v->id, 0x14BEu);
  EXPECT_EQ(v->type, "u32");
  EXPECT_EQ(v->max, 0x7FFFFFFF);
  EXPECT_TRUE(v->has_stored_value);
  EXPECT_EQ(cat->Find("14BEh")->id, 0x14BEu);
  EXPECT_EQ(cat->Find("5310")->id, 0x14BEu);
  EXPECT_EQ(cat->Find("0x14C1")->max, 0x5FFFFFFF);  // MC22 L3836
  auto actual = cat->Find("0x1B8D");
  ASSERT_TRUE(actual.ok());
  EXPECT_FALSE(actual->writable);
  EXPECT_FALSE(actual->has_stored_value);
  auto raw = cat->Find("0xABCD");
  ASSERT_TRUE(raw.ok());
  EXPECT_EQ(raw->id, 0xABCDu);
  EXPECT_EQ(raw->type, "unknown");
  EXPECT_EQ(cat->Find("0x10000").status().code(), absl::StatusCode::kNotFound);
}

TEST(LinMotDevicenetCatalogue, SetIdsGetHalvesAndNames) {
  const auto cat = linmot::devicenet::LinMotDevicenetParameterCatalogue();
  auto speed = cat->Find("0x51");
  ASSERT_TRUE(speed.ok()) << speed.status();
  EXPECT_EQ(speed->name, "0x51");
  EXPECT_EQ(cat->Find("0x50")->id, 0x51u);  // the Get half
  EXPECT_EQ(cat->Find("set_filter_max_speed")->id, 0x51u);
  EXPECT_EQ(cat->Find("Get Filter Max Speed")->id, 0x51u);
  // Names in any ASCII case, ids as "0X51" or "51h" (NameEqualsIgnoreCase, ParseParameterId).
  EXPECT_EQ(cat->Find("SET_FILTER_MAX_SPEED")->id, 0x51u);
  EXPECT_EQ(cat->Find("0X51")->id, 0x51u);
  EXPECT_EQ(cat->Find("51h")->id, 0x51u);
  auto acc = cat->Find("0x53");
  ASSERT_TRUE(acc.ok());
  EXPECT_EQ(acc->min, 1);  // decision 906: 1..1536
  EXPECT_EQ(acc->max, 1536);
  EXPECT_FALSE(acc->has_stored_value);
  EXPECT_EQ(cat->Find("0x11").status().code(), absl::StatusCode::kNotFound);  // motion, not §8.9
  for (const ParameterDefinition& d : cat->Definitions()) EXPECT_EQ(d.id % 2, 1u) << d.name;
}

}  // namespace
}  // namespace drivegw
