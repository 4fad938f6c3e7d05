// Curve sets: one row per set pointing at its newest immutable version, optimistic concurrency by
// etag, curves as one JSON array per version (decision 411; same scheme as decision 410).
#include "storage/curve_set_repo.h"

#include <limits>
#include <nlohmann/json.hpp>
#include <utility>

#include "absl/strings/str_cat.h"
#include "adapters/core/status.h"
#include "storage/versioned_set_store.h"

namespace drivegw::storage {
namespace {

using internal::ReadTime;
using nlohmann::json;
using LM = LinMotParametricCurve;

constexpr int kDefaultLimit = 100;
constexpr const char* kKindPositionTime = "position_time";
constexpr const char* kKindLinMot = "linmot";
constexpr const char* kYUnitPosition = "position_0.1um";  // linmot-mc.md §7 L1001

// Migration 003; same scheme as parameter sets (decision 411).
constexpr internal::VersionedSetNames kNames{"curve_sets", "curve_set_versions", "curves_json",
                                             "curve_set",  "curve set",          "curve set"};

internal::VersionedSetStore Store(Db& db) { return internal::VersionedSetStore(db, kNames); }

absl::Status ValidateForWrite(const internal::VersionedSetStore& store, const CurveSet& set) {
  DGW_RETURN_IF_ERROR(store.ValidateName(set.name));
  return ValidateCurveSetShape(set);
}

std::string SetLabel(std::string_view name) { return internal::SetLabel(kNames, name); }

// ---- JSON --------------------------------------------------------------------------------------

json CurveToJson(const Curve& c) {
  json j = {{"name", c.name}, {"description", c.description}};
  if (const auto* pt = std::get_if<PositionTimeCurve>(&c.shape)) {
    j["kind"] = kKindPositionTime;
    j["time_step_s"] = pt->time_step_s;
    j["positions_mm"] = pt->positions_mm;
  } else {
    const auto& lm = std::get<LM>(c.shape);
    j["kind"] = kKindLinMot;
    j["curve_id"] = lm.curve_id;
    j["x_length_s"] = lm.x_length_s;
    j["y_unit"] = kYUnitPosition;
    j["points"] = lm.points;
    j["offset_mm"] = lm.offset_mm;
    j["amplitude_scale_pct"] = lm.amplitude_scale_pct;
    j["time_scale_pct"] = lm.time_scale_pct;
  }
  return j;
}

absl::Status Bad(std::string_view context, std::string_view why) {
  return absl::DataLossError(absl::StrCat("storage: stored curves of ", std::string(context),
                                          " are malformed: ", std::string(why)));
}

bool GetString(const json& obj, const char* key, std::string& out) {
  const auto it = obj.find(key);
  if (it == obj.end() || !it->is_string()) return false;
  out = it->get<std::string>();
  return true;
}

bool GetDouble(const json& obj, const char* key, double& out) {
  const auto it = obj.find(key);
  if (it == obj.end() || !it->is_number()) return false;
  out = it->get<double>();
  return true;
}

bool IsInt32(const json& v) {
  if (v.is_number_unsigned()) {
    return v.get<uint64_t>() <= static_cast<uint64_t>(std::numeric_limits<int32_t>::max());
  }
  if (!v.is_number_integer()) return false;
  const int64_t n = v.get<int64_t>();
  return n >= std::numeric_limits<int32_t>::min() && n <= std::numeric_limits<int32_t>::max();
}

absl::StatusOr<Curve> CurveFromJson(const json& e, const std::string& at,
                                    std::string_view context) {
  if (!e.is_object()) return Bad(context, absl::StrCat(at, " is not an object"));
  Curve c;
  std::string kind;
  if (!GetString(e, "name", c.name)) {
    return Bad(context, absl::StrCat(at, ".name is missing or not a string"));
  }
  GetString(e, "description", c.description);  // optional
  if (!GetString(e, "kind", kind)) {
    return Bad(context, absl::StrCat(at, ".kind is missing or not a string"));
  }
  if (kind == kKindPositionTime) {
    PositionTimeCurve pt;
    if (!GetDouble(e, "time_step_s", pt.time_step_s)) {
      return Bad(context, absl::StrCat(at, ".time_step_s is missing or not a number"));
    }
    const auto ps = e.find("positions_mm");
    if (ps == e.end() || !ps->is_array()) {
      return Bad(context, absl::StrCat(at, ".positions_mm is missing or not an array"));
    }
    for (size_t i = 0; i < ps->size(); ++i) {
      if (!(*ps)[i].is_number()) {
        return Bad(context, absl::StrCat(at, ".positions_mm[", i, "] is not a number"));
      }
      pt.positions_mm.push_back((*ps)[i].get<double>());
    }
    c.shape = std::move(pt);
    return c;
  }
  if (kind != kKindLinMot) {
    return Bad(context, absl::StrCat(at, ".kind '", kind, "' is not ", kKindPositionTime, " or ",
                                     kKindLinMot));
  }
  LM lm;
  const auto id = e.find("curve_id");
  if (id == e.end() || !IsInt32(*id)) {
    return Bad(context, absl::StrCat(at, ".curve_id is missing or not an integer"));
  }
  lm.curve_id = id->get<int>();
  std::string unit;
  if (!GetString(e, "y_unit", unit) || unit != kYUnitPosition) {
    return Bad(context, absl::StrCat(at, ".y_unit is not '", kYUnitPosition, "'"));
  }
  for (auto [key, field] :
       {std::pair{"x_length_s", &lm.x_length_s}, std::pair{"offset_mm", &lm.offset_mm},
        std::pair{"amplitude_scale_pct", &lm.amplitude_scale_pct},
        std::pair{"time_scale_pct", &lm.time_scale_pct}}) {
    if (!GetDouble(e, key, *field)) {
      return Bad(context, absl::StrCat(at, ".", key, " is missing or not a number"));
    }
  }
  const auto ps = e.find("points");
  if (ps == e.end() || !ps->is_array()) {
    return Bad(context, absl::StrCat(at, ".points is missing or not an array"));
  }
  for (size_t i = 0; i < ps->size(); ++i) {
    if (!IsInt32((*ps)[i])) {
      return Bad(context, absl::StrCat(at, ".points[", i, "] is not a 32-bit integer"));
    }
    lm.points.push_back((*ps)[i].get<int32_t>());
  }
  c.shape = std::move(lm);
  return c;
}

// ---- rows --------------------------------------------------------------------------------------

// The join of a set with its newest version; ReadSet() reads these columns in this order.
constexpr const char* kSetColumns =
    "SELECT s.name, s.description, s.created_at, s.updated_at, s.version, s.etag, v.author, "
    "v.curves_json FROM curve_sets s "
    "JOIN curve_set_versions v ON v.set_name = s.name AND v.version = s.version";

absl::StatusOr<StoredCurveSet> ReadSet(const Statement& stmt) {
  StoredCurveSet s;
  s.set.name = stmt.ColumnText(0);
  s.set.description = stmt.ColumnText(1);
  s.created_at = ReadTime(stmt, 2);
  s.updated_at = ReadTime(stmt, 3);
  s.version = stmt.ColumnInt(4);
  s.etag = stmt.ColumnText(5);
  s.author = stmt.ColumnText(6);
  DGW_ASSIGN_OR_RETURN(s.set.curves,
                       CurvesFromJson(stmt.ColumnText(7),
                                      absl::StrCat(SetLabel(s.set.name), " version ", s.version)));
  return s;
}

absl::StatusOr<CurveSetVersion> DecodeVersion(const internal::VersionRow& row,
                                              std::string_view name) {
  auto v = internal::VersionFields<CurveSetVersion>(row);
  DGW_ASSIGN_OR_RETURN(
      v.curves, CurvesFromJson(row.payload, absl::StrCat(SetLabel(name), " version ", v.version)));
  return v;
}

}  // namespace

absl::StatusOr<std::string> CurvesToJson(const std::vector<Curve>& curves) {
  json out = json::array();
  for (const Curve& c : curves) out.push_back(CurveToJson(c));
  try {
    // dump() throws type_error 316 on invalid UTF-8 in a name or description.
    return out.dump();
  } catch (const json::exception& e) {
    return absl::InvalidArgumentError(
        absl::StrCat("curve_set.curves: text is not valid UTF-8 (", e.what(), ")"));
  }
}

absl::StatusOr<std::vector<Curve>> CurvesFromJson(std::string_view text, std::string_view context) {
  const json j = json::parse(text, nullptr, /*allow_exceptions=*/false);
  if (j.is_discarded()) return Bad(context, "not JSON");
  if (!j.is_array()) return Bad(context, "not an array");
  std::vector<Curve> out;
  out.reserve(j.size());
  for (size_t i = 0; i < j.size(); ++i) {
    DGW_ASSIGN_OR_RETURN(Curve c, CurveFromJson(j[i], absl::StrCat("curves[", i, "]"), context));
    out.push_back(std::move(c));
  }
  return out;
}

absl::StatusOr<StoredCurveSet> CurveSetRepo::Create(const CurveSet& set, std::string_view author,
                                                    std::string_view comment) {
  const internal::VersionedSetStore store = Store(*db_);
  DGW_RETURN_IF_ERROR(ValidateForWrite(store, set));
  DGW_ASSIGN_OR_RETURN(const std::string curves_json, CurvesToJson(set.curves));
  const auto insert_row = [&](const std::string& ts, const std::string& etag) -> absl::Status {
    DGW_ASSIGN_OR_RETURN(Statement insert,
                         db_->Prepare("INSERT INTO curve_sets (name, description, created_at, "
                                      "updated_at, version, etag) VALUES (?1, ?2, ?3, ?3, 1, ?4)"));
    DGW_RETURN_IF_ERROR(insert.Bind(1, std::string_view(set.name)));
    DGW_RETURN_IF_ERROR(insert.Bind(2, std::string_view(set.description)));
    DGW_RETURN_IF_ERROR(insert.Bind(3, std::string_view(ts)));
    DGW_RETURN_IF_ERROR(insert.Bind(4, std::string_view(etag)));
    return insert.Run();
  };
  return store.Create<StoredCurveSet>(set.name, author, comment, curves_json, insert_row,
                                      [this](std::string_view name) { return Get(name); });
}

absl::StatusOr<StoredCurveSet> CurveSetRepo::Get(std::string_view name) {
  return Store(*db_).GetSet(kSetColumns, name, ReadSet);
}

absl::StatusOr<std::vector<StoredCurveSet>> CurveSetRepo::List(const CurveSetQuery& query) {
  DGW_RETURN_IF_ERROR(
      internal::CheckLimit(query.limit, CurveSetQuery::kMaxLimit, "curve_set_query.limit"));
  const int limit = query.limit == 0 ? kDefaultLimit : query.limit;
  std::string sql(kSetColumns);
  int next = 1;
  int after_index = 0;
  if (query.after_name) absl::StrAppend(&sql, " WHERE s.name > ?", after_index = next++);
  // BINARY collation: byte order, the same order clients see and page by.
  absl::StrAppend(&sql, " ORDER BY s.name LIMIT ?", next);

  auto lock = db_->Lock();
  DGW_ASSIGN_OR_RETURN(Statement stmt, db_->Prepare(sql));
  if (after_index) DGW_RETURN_IF_ERROR(stmt.Bind(after_index, std::string_view(*query.after_name)));
  DGW_RETURN_IF_ERROR(stmt.Bind(next, limit));
  return internal::ReadAll<StoredCurveSet>(stmt, ReadSet);
}

absl::StatusOr<StoredCurveSet> CurveSetRepo::Update(const CurveSet& set,
                                                    std::string_view expected_etag,
                                                    std::string_view author,
                                                    std::string_view comment) {
  const internal::VersionedSetStore store = Store(*db_);
  DGW_RETURN_IF_ERROR(ValidateForWrite(store, set));
  DGW_ASSIGN_OR_RETURN(const std::string curves_json, CurvesToJson(set.curves));
  const auto update_row = [&](const std::string& ts, int version,
                              const std::string& etag) -> absl::Status {
    DGW_ASSIGN_OR_RETURN(Statement update,
                         db_->Prepare("UPDATE curve_sets SET description = ?2, updated_at = ?3, "
                                      "version = ?4, etag = ?5 WHERE name = ?1"));
    DGW_RETURN_IF_ERROR(update.Bind(1, std::string_view(set.name)));
    DGW_RETURN_IF_ERROR(update.Bind(2, std::string_view(set.description)));
    DGW_RETURN_IF_ERROR(update.Bind(3, std::string_view(ts)));
    DGW_RETURN_IF_ERROR(update.Bind(4, version));
    DGW_RETURN_IF_ERROR(update.Bind(5, std::string_view(etag)));
    return update.Run();
  };
  return store.Update<StoredCurveSet>(set.name, expected_etag, author, comment, curves_json,
                                      update_row,
                                      [this](std::string_view name) { return Get(name); });
}

absl::Status CurveSetRepo::Delete(std::string_view name, std::string_view expected_etag) {
  return Store(*db_).Delete(name, expected_etag);
}

absl::StatusOr<std::vector<CurveSetVersion>> CurveSetRepo::ListVersions(std::string_view name) {
  DGW_ASSIGN_OR_RETURN(const std::vector<internal::VersionRow> rows,
                       Store(*db_).ListVersions(name));
  return internal::DecodeVersions<CurveSetVersion>(
      rows, [&](const internal::VersionRow& row) { return DecodeVersion(row, name); });
}

absl::StatusOr<CurveSetVersion> CurveSetRepo::GetVersion(std::string_view name, int version) {
  DGW_ASSIGN_OR_RETURN(const internal::VersionRow row, Store(*db_).GetVersion(name, version));
  return DecodeVersion(row, name);
}

}  // namespace drivegw::storage
