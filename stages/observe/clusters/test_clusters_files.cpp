// observe.clusters' CSV files: the size histogram's columns (size_columns) and the long layout
// (sizes_layout: long), and both across a checkpoint, including one of the wide rows written
// before session 40.
#include <catch2/catch.hpp>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <random>
#include <sstream>

#include "stages/observe/clusters/test_support.h"

using namespace ff;
using namespace ff::test::clusters_test;
using ff::test::ParamSettings;

namespace {

// The header and the rows of a CSV after its '#' lines, split at the commas.
std::vector<std::vector<std::string>> csv_cells(const std::filesystem::path& file) {
  std::ifstream in(file);
  std::vector<std::vector<std::string>> out;
  for (std::string line; std::getline(in, line);) {
    if (line.empty() || line[0] == '#') continue;
    std::vector<std::string> cells;
    std::stringstream ss(line);
    for (std::string c; std::getline(ss, c, ',');) cells.push_back(c);
    out.push_back(cells);
  }
  return out;
}

}  // namespace

TEST_CASE("observe.clusters: size_columns sets the size histogram's columns, the last one for K or more",
          "[clusters][sizes]") {
  const double L[3] = {20, 20, 0};
  auto s = make_state(2, lattice_pieces(), L);
  const std::filesystem::path dir = std::filesystem::temp_directory_path() / "flipflow_cluster_size_columns";
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  test::StageDriver drv(Backend::cpu, Precision::f64, 2);
  // The sizes row of one call at step 3 (its counts after step and time) and the header.
  auto sizes = [&](std::int64_t k, std::vector<std::string>* header = nullptr) {
    auto st = clusters(2, {{"size_columns", k}}, dir.string());
    st->configure(*s);
    drv.run(*st, *s, 3);
    st->finish(*s, true);
    const auto cells = csv_cells(dir / "cluster_sizes.csv");
    REQUIRE(cells.size() == 2);  // header, one row
    if (header) *header = cells[0];
    REQUIRE(cells[1].size() == cells[0].size());
    CHECK(cells[1][0] == "3");
    std::vector<double> counts;
    for (std::size_t c = 2; c < cells[1].size(); ++c) counts.push_back(std::stod(cells[1][c]));
    return counts;
  };
  // K = 4: three monomers, one dimer, no trimer; the 4-chain and the 3x3 block are "4 or more".
  std::vector<std::string> header;
  CHECK(sizes(4, &header) == std::vector<double>{3, 1, 0, 2});
  CHECK(header == std::vector<std::string>{"step", "time", "n1", "n2", "n3", "n4plus"});
  // K = 2: everything but the monomers is in the last column.
  CHECK(sizes(2, &header) == std::vector<double>{3, 3});
  CHECK(header.back() == "n2plus");
  // K = 10: the block of 9 has its own column, the last (10 or more) is empty.
  const auto ten = sizes(10);
  CHECK(ten == std::vector<double>{3, 1, 0, 1, 0, 0, 0, 0, 1, 0});
  // The default is unchanged: n1 ... n63, n64plus, the block in n9.
  const auto def = sizes(64, &header);
  REQUIRE(def.size() == 64);
  CHECK(def[8] == 1);
  CHECK(header[2 + 62] == "n63");
  CHECK(header.back() == "n64plus");

  // The range: at least 2 (one column of sizes and the plus column), at most 10^6.
  const auto& params = registry().get("observe.clusters").decl.params;
  const auto spec = std::find_if(params.begin(), params.end(), [](const ParamSpec& p) { return p.name == "size_columns"; });
  REQUIRE(spec != params.end());
  CHECK(check_param(*spec, ParamValue(std::int64_t(1))) != "");
  CHECK(check_param(*spec, ParamValue(std::int64_t(2))) == "");
  CHECK(check_param(*spec, ParamValue(std::int64_t(1000000))) == "");
  CHECK(check_param(*spec, ParamValue(std::int64_t(1000001))) != "");

  // The long layout: a row per size present, every size exact (the block of 9 too), K unused.
  auto long_rows = [&](Stage& st) {
    st.finish(*s, true);
    const auto cells = csv_cells(dir / "cluster_sizes.csv");
    REQUIRE(!cells.empty());
    CHECK(cells[0] == std::vector<std::string>{"step", "time", "size", "clusters"});
    std::vector<std::vector<std::string>> out;
    for (std::size_t r = 1; r < cells.size(); ++r) out.push_back({cells[r][0], cells[r][2], cells[r][3]});
    return out;
  };
  using Rows = std::vector<std::vector<std::string>>;
  const Rows lattice_long = {{"3", "1", "3"}, {"3", "2", "1"}, {"3", "4", "1"}, {"3", "9", "1"}};
  {
    auto st = clusters(2, {{"sizes_layout", std::string("long")}, {"size_columns", std::int64_t(2)}}, dir.string());
    st->configure(*s);
    drv.run(*st, *s, 3);
    CHECK(long_rows(*st) == lattice_long);
  }

  // A continuation: the rows come back with their exact sizes, so the same, a smaller or a larger
  // K, or the other layout, continue them.
  auto st = clusters(2, {{"size_columns", std::int64_t(4)}});
  st->configure(*s);
  drv.run(*st, *s, 3);
  StageState saved;
  st->save_state(saved);
  auto same = clusters(2, {{"size_columns", std::int64_t(4)}}, dir.string());
  same->configure(*s);
  same->restore_state(saved, *s);
  drv.run(*same, *s, 5);
  same->finish(*s, true);
  auto rows = csv_cells(dir / "cluster_sizes.csv");
  REQUIRE(rows.size() == 3);
  CHECK(rows[1][0] == "3");
  CHECK(rows[2][0] == "5");
  for (int r = 1; r <= 2; ++r) CHECK(std::vector<std::string>(rows[r].begin() + 2, rows[r].end()) ==
                                     std::vector<std::string>{"3", "1", "0", "2"});
  // The restored row with K columns, and the checkpoint restored into the stage's `k`.
  auto continued = [&](const StageState& from, const ParamSettings& set) {
    auto c = clusters(2, set, dir.string());
    c->configure(*s);
    c->restore_state(from, *s);
    c->finish(*s, true);
    const auto cells = csv_cells(dir / "cluster_sizes.csv");
    REQUIRE(cells.size() == 2);
    return std::vector<std::string>(cells[1].begin() + 2, cells[1].end());
  };
  CHECK(continued(saved, {{"size_columns", std::int64_t(2)}}) == std::vector<std::string>{"3", "3"});
  CHECK(continued(saved, {{"size_columns", std::int64_t(10)}}) ==
        std::vector<std::string>{"3", "1", "0", "1", "0", "0", "0", "0", "1", "0"});
  {
    auto c = clusters(2, {{"sizes_layout", std::string("long")}}, dir.string());
    c->configure(*s);
    c->restore_state(saved, *s);
    CHECK(long_rows(*c) == lattice_long);
  }

  // A checkpoint of flipflow before session 40 kept the wide rows (here K = 4: n1 n2 n3 n4plus):
  // the same or a smaller K continue them; a larger K or the long layout would have to split the
  // last column, and are refused, unless that column is empty.
  auto old_checkpoint = [](std::vector<double> size_row) {
    StageState old;
    old.put("rows.length", std::vector<std::uint64_t>{});
    old.put("rows", std::vector<double>{});
    old.put("size_rows.length", std::vector<std::uint64_t>{size_row.size()});
    old.put("size_rows", size_row);
    old.put("fallbacks", std::uint64_t(0));
    old.put("warned", std::uint8_t(0));
    return old;
  };
  const StageState old = old_checkpoint({3, 0.03, 3, 1, 0, 2});
  CHECK(continued(old, {{"size_columns", std::int64_t(4)}}) == std::vector<std::string>{"3", "1", "0", "2"});
  CHECK(continued(old, {{"size_columns", std::int64_t(2)}}) == std::vector<std::string>{"3", "3"});
  auto more = clusters(2, {{"size_columns", std::int64_t(8)}});
  more->configure(*s);
  CHECK_THROWS_WITH(more->restore_state(old, *s), Catch::Contains("size_columns = 4 (a checkpoint of flipflow before "
                                                                  "session 40), fewer than size_columns = 8"));
  auto longer = clusters(2, {{"sizes_layout", std::string("long")}});
  longer->configure(*s);
  CHECK_THROWS_WITH(longer->restore_state(old, *s), Catch::Contains("cannot be written with sizes_layout: long"));
  CHECK(continued(old_checkpoint({3, 0.03, 3, 1, 0, 0}), {{"size_columns", std::int64_t(6)}}) ==
        std::vector<std::string>{"3", "1", "0", "0", "0", "0"});
  std::filesystem::remove_all(dir);
}
