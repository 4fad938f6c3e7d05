// ParameterSetServiceCore checks the lease of every target drive before an apply writes (a dry run
// only reads); map-backed drives (tests/server/apply/map_drive.h) record every write.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <chrono>
#include <memory>

#include "server/core/lease_manager.h"
#include "server/core/parameter_apply.h"
#include "server/core/parameter_set_service.h"
#include "storage/db.h"
#include "storage/migrations.h"
#include "storage/parameter_set_repo.h"
#include "tests/server/apply/map_drive.h"
#include "tests/storage/temp_dir.h"

namespace drivegw::server {
namespace {

using namespace std::chrono_literals;
using ::testing::HasSubstr;

// Two writable parameters p1, p2 of family "fake".
class TwoParameters final : public ParameterCatalogue {
 public:
  TwoParameters() {
    for (uint32_t i = 1; i <= 2; ++i) {
      ParameterDefinition d;
      d.id = i;
      d.name = "p" + std::to_string(i);
      d.type = "i32";
      d.min = 0;
      d.max = 1000;
      d.writable = true;
      defs_.push_back(d);
    }
  }
  std::string family() const override { return "fake"; }
  const std::vector<ParameterDefinition>& Definitions() const override { return defs_; }
  absl::StatusOr<ParameterDefinition> Find(std::string_view name) const override {
    for (const auto& d : defs_) {
      if (d.name == name) return d;
    }
    return absl::NotFoundError("fake: no parameter '" + std::string(name) + "'");
  }

 private:
  std::vector<ParameterDefinition> defs_;
};

CallContext Who(std::string principal) {
  CallContext c;
  c.principal = std::move(principal);
  return c;
}

TEST(ParameterApplyLease, OtherPrincipal_RefusedBeforeAnyWrite_DryRunOpen) {
  storage::testing::TempDir dir;
  auto db = storage::Db::Open(dir.File("gw.db"));
  ASSERT_TRUE(db.ok()) << db.status();
  ASSERT_TRUE(storage::Migrate(*db).ok());
  storage::ParameterSetRepo repo(*db);
  CatalogueList catalogues{std::make_shared<TwoParameters>()};
  auto x1 = std::make_shared<test_support::MapDrive>("x1", "fake",
                                                     std::map<uint32_t, int64_t>{{1, 1}, {2, 2}});
  auto x2 = std::make_shared<test_support::MapDrive>("x2", "fake",
                                                     std::map<uint32_t, int64_t>{{1, 1}, {2, 2}});
  // Declared after the drives: its destructor waits for running operations before they go.
  ParameterApplier applier(repo, catalogues);
  LeaseManager leases;
  ParameterSetServiceCore core(repo, applier, catalogues, {x1, x2}, nullptr, &leases);
  v1::CreateParameterSetRequest create;
  create.mutable_parameter_set()->set_name("parameterSets/slow");
  create.mutable_parameter_set()->set_family("fake");
  auto* pv = create.mutable_parameter_set()->add_parameters();
  pv->set_parameter("p1");
  pv->set_value(300);
  ASSERT_TRUE(core.CreateParameterSet(create, Who("eng")).ok());
  ASSERT_TRUE(leases.Acquire("x2", Who("mes-line-3"), 30s).ok());

  v1::ApplyParameterSetRequest apply;
  apply.set_name("slow");
  apply.add_drives("x1");
  apply.add_drives("x2");
  const absl::Status s = core.ApplyParameterSet(apply, Who("eng")).status();
  EXPECT_EQ(s.code(), absl::StatusCode::kFailedPrecondition);
  EXPECT_THAT(std::string(s.message()), HasSubstr("drive 'x2' is leased by 'mes-line-3'"));
  EXPECT_EQ(x1->write_calls(), 0);  // refused before the operation started
  apply.set_dry_run(true);
  EXPECT_TRUE(core.ApplyParameterSet(apply, Who("eng")).ok());
  // The holder applies.
  apply.set_dry_run(false);
  EXPECT_TRUE(core.ApplyParameterSet(apply, Who("mes-line-3")).ok());
}

}  // namespace
}  // namespace drivegw::server
