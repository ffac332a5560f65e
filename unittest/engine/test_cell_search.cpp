/* HARDSPHERE_GPU unit tests: the candidate search (engine/cell_search.h) against all pairs.

   Points with radii of several sizes, some of them "ghosts" (index >= nsearch, not searched
   from); the search must return every pair within r_i + r_j + extra with at least one
   searched point, each once, as (lower index, higher index), and no other. */
#include "engine/cell_search.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <random>
#include <set>
#include <utility>
#include <vector>

using HSGPU::Collide::CellSearch;

namespace {

struct Cloud {
  std::vector<double> x, rad;
  int n = 0, nsearch = 0;
  double rmax = 0.0;
};

// n points uniform in a box of edge len (flat in z when flat), radii in [rlo, rhi].
Cloud make_cloud(int n, int nsearch, double len, double rlo, double rhi, bool flat, unsigned seed)
{
  std::mt19937 gen(seed);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  Cloud c;
  c.n = n;
  c.nsearch = nsearch;
  for (int i = 0; i < n; ++i) {
    c.x.push_back(len * u(gen));
    c.x.push_back(len * u(gen));
    c.x.push_back(flat ? 0.5 : len * u(gen));
    c.rad.push_back(rlo + (rhi - rlo) * u(gen));
    c.rmax = std::max(c.rmax, c.rad.back());
  }
  return c;
}

std::set<std::pair<int, int>> brute_force(const Cloud &c, double extra)
{
  std::set<std::pair<int, int>> out;
  for (int i = 0; i < c.n; ++i)
    for (int j = i + 1; j < c.n; ++j) {
      if (i >= c.nsearch && j >= c.nsearch) continue;
      double d2 = 0.0;
      for (int d = 0; d < 3; ++d) {
        const double r = c.x[3 * i + d] - c.x[3 * j + d];
        d2 += r * r;
      }
      const double range = c.rad[i] + c.rad[j] + extra;
      if (d2 <= range * range) out.insert({i, j});
    }
  return out;
}

void expect_same_pairs(const Cloud &c, double extra)
{
  CellSearch search;
  std::vector<int> pairs;
  search.find(c.x.data(), c.rad.data(), c.n, c.nsearch, c.rmax, extra, pairs);
  ASSERT_EQ(pairs.size() % 2, 0u);
  std::set<std::pair<int, int>> found;
  for (size_t k = 0; k < pairs.size(); k += 2) {
    const int i = pairs[k], j = pairs[k + 1];
    EXPECT_LT(i, j);
    EXPECT_LT(i, c.nsearch) << "a pair of two points not searched from";
    EXPECT_TRUE(found.insert({i, j}).second) << "pair " << i << " " << j << " twice";
  }
  const auto want = brute_force(c, extra);
  EXPECT_EQ(found.size(), want.size());
  EXPECT_TRUE(found == want);
  EXPECT_GT(want.size(), 0u);    // the case tests something
  // neighbors(i) holds every point within the cell width of point i.
  std::vector<int> near;
  for (int i = 0; i < c.n; i += 7) {
    near.clear();
    search.neighbors(i, near);
    const std::set<int> in(near.begin(), near.end());
    for (int j = 0; j < c.n; ++j) {
      double d2 = 0.0;
      for (int d = 0; d < 3; ++d) {
        const double r = c.x[3 * i + d] - c.x[3 * j + d];
        d2 += r * r;
      }
      if (d2 < search.cell_width() * search.cell_width()) {
        EXPECT_TRUE(in.count(j)) << "point " << j << " near " << i;
      }
    }
  }
}

}    // namespace

TEST(CellSearch, DenseAllSearchedEqualsAllPairs)
{
  expect_same_pairs(make_cloud(1500, 1500, 12.0, 0.4, 0.6, false, 1), 1e-9);
}

TEST(CellSearch, GhostsOnlyPairedWithSearchedPoints)
{
  expect_same_pairs(make_cloud(1500, 900, 12.0, 0.3, 0.9, false, 2), 1e-9);
}

TEST(CellSearch, PolydisperseWithMargin)
{
  expect_same_pairs(make_cloud(800, 700, 15.0, 0.1, 1.5, false, 3), 0.05);
}

TEST(CellSearch, FlatLayerAndFewCells)
{
  // One cell layer in z and two cells across: the stencil is clipped on every side.
  expect_same_pairs(make_cloud(400, 300, 10.0, 0.2, 0.5, true, 4), 1e-9);
  expect_same_pairs(make_cloud(60, 50, 4.0, 0.5, 0.9, false, 5), 1e-9);
}

TEST(CellSearch, DiluteCloudGetsWiderCells)
{
  // Far more cell volume than points: the grid is coarsened to about 2 n cells.
  Cloud c = make_cloud(300, 300, 400.0, 0.5, 2.0, false, 6);
  // A few close pairs, so that the case tests something.
  for (int k = 0; k < 20; ++k)
    for (int d = 0; d < 3; ++d) c.x[3 * (2 * k + 1) + d] = c.x[3 * (2 * k) + d] + 0.3 * (d + 1);
  CellSearch search;
  std::vector<int> pairs;
  search.find(c.x.data(), c.rad.data(), c.n, c.nsearch, c.rmax, 1e-9, pairs);
  EXPECT_LE(search.cells(), 2L * c.n + 27);
  expect_same_pairs(c, 1e-9);
}

// Diameters 1 and 10 (issue 12 item 8): a few large points among many small ones are searched
// in a class of their own, against the small points' cells within their own range; still every
// pair once, and within(i, range) holds every point within range of point i.
TEST(CellSearch, FewLargeAmongManySmallAreSearchedApart)
{
  Cloud c = make_cloud(3000, 2400, 20.0, 0.45, 0.6, false, 7);
  std::mt19937 gen(8);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  for (int k = 0; k < 40; ++k) {    // large points, some of them ghosts
    const int i = (int) (u(gen) * c.n);
    c.rad[i] = 4.5 + u(gen);
    c.rmax = std::max(c.rmax, c.rad[i]);
  }
  CellSearch search;
  std::vector<int> pairs;
  search.find(c.x.data(), c.rad.data(), c.n, c.nsearch, c.rmax, 1e-9, pairs);
  EXPECT_GT(search.large_points(), 0);
  EXPECT_LE(search.large_points(), c.n / 32);
  EXPECT_LT(search.cell_width(), 2.0 * 4.5) << "small cells sized for the small points";
  expect_same_pairs(c, 1e-9);
  std::vector<int> out;
  for (int i = 0; i < c.n; i += 13) {
    const double range = 0.7 + (i % 5);
    out.clear();
    search.within(i, range, out);
    const std::set<int> in(out.begin(), out.end());
    for (int j = 0; j < c.n; ++j) {
      double d2 = 0.0;
      for (int d = 0; d < 3; ++d) {
        const double r = c.x[3 * i + d] - c.x[3 * j + d];
        d2 += r * r;
      }
      if (d2 <= range * range) {
        EXPECT_TRUE(in.count(j)) << "point " << j << " within " << range << " of " << i;
      }
    }
  }
}

// Sizes spread evenly (no few large ones): one class, as before.
TEST(CellSearch, EvenSpreadOfSizesKeepsOneClass)
{
  Cloud c = make_cloud(1000, 1000, 15.0, 0.3, 1.0, false, 9);
  CellSearch search;
  std::vector<int> pairs;
  search.find(c.x.data(), c.rad.data(), c.n, c.nsearch, c.rmax, 1e-9, pairs);
  EXPECT_EQ(search.large_points(), 0);
  EXPECT_GE(search.cell_width(), 2.0 * c.rmax);
}
