// WindowChooser's planned windows (engine/window_chooser.h): every window of a step as long,
// that length following the previous steps' largest groups over the target.

#include "engine/window_chooser.h"

#include <gtest/gtest.h>

using HSGPU::Collide::WindowChooser;

TEST(WindowChooser, PlannedWindowsAreEqualAndTheLastIsCutShort)
{
  WindowChooser c;
  const double dt = 0.01;
  EXPECT_DOUBLE_EQ(c.planned(), 0.5);
  EXPECT_DOUBLE_EQ(c.planned_end(0.0, dt), 0.005);
  EXPECT_EQ(c.planned_end(0.005, dt), dt);    // the step's end itself, not a rounding of it
  EXPECT_TRUE(c.plan_feedback(3.0));            // 0.25
  EXPECT_TRUE(c.plan_feedback(1.5));            // 0.125
  EXPECT_DOUBLE_EQ(c.planned(), 0.125);
  EXPECT_DOUBLE_EQ(c.planned_end(0.00875, dt), dt);
}

// Groups that shrink with the windows (a fluid): the windows halve while the largest group is
// above the target, and the length that was too long is not planned again for 256 steps.
TEST(WindowChooser, PlannedWindowsHalveWhileItHelpsAndKeepOffTooLongOnes)
{
  WindowChooser c;
  EXPECT_TRUE(c.plan_feedback(3.0));
  EXPECT_DOUBLE_EQ(c.planned(), 0.25);
  EXPECT_TRUE(c.plan_feedback(2.0));    // above the target, but 2/3 of what it was
  EXPECT_DOUBLE_EQ(c.planned(), 0.125);
  EXPECT_TRUE(c.plan_feedback(0.1));    // would double, but 0.25 made too large a group
  EXPECT_DOUBLE_EQ(c.planned(), 0.125);
  int steps = 1;
  while (c.planned() == 0.125 && steps < 1000) {
    EXPECT_TRUE(c.plan_feedback(0.1));
    ++steps;
  }
  EXPECT_EQ(steps, 256);
  EXPECT_DOUBLE_EQ(c.planned(), 0.25);
  EXPECT_TRUE(c.plan_feedback(0.1));
  EXPECT_DOUBLE_EQ(c.planned(), 0.5);
  EXPECT_TRUE(c.plan_feedback(0.5));    // between 1/4 and 1: kept
  EXPECT_DOUBLE_EQ(c.planned(), 0.5);
}

// A group that stays as large however short the windows (a settling pile): after one halving
// that did not shrink it below 4/5, planning stops (false) and the halving is undone; as short
// as they get, it stops too.  Halving the windows down to dt/16 each step had made the pour on
// 4 ranks 5x slower per step.
TEST(WindowChooser, PlannedWindowsStopWhereHalvingDoesNotHelp)
{
  WindowChooser c;
  EXPECT_TRUE(c.plan_feedback(4.0));
  EXPECT_DOUBLE_EQ(c.planned(), 0.25);
  EXPECT_FALSE(c.plan_feedback(3.5));
  EXPECT_DOUBLE_EQ(c.planned(), 0.5);
  // Shrinking by more than a fifth each time: down to dt/16, then stop.
  WindowChooser d;
  double r = 100.0;
  int halvings = 0;
  while (d.plan_feedback(r)) {
    r *= 0.5;
    ++halvings;
    ASSERT_LT(halvings, 10);
  }
  EXPECT_EQ(halvings, 3);    // 0.5 -> 1/4, 1/8, 1/16, then at the shortest
  EXPECT_DOUBLE_EQ(d.planned(), 1.0 / 16.0);
}
