#include <gtest/gtest.h>

#include <QImage>
#include <cmath>
#include <numeric>

#include "gui_test_app.h"
#include "plot_widget.h"

using mrsns::gui::PlotWidget;

TEST(PlotWidget, HistogramCountsEveryFiniteValueInItsBin) {
  mrsns::test::guiApp();
  PlotWidget plot;
  // 0..9 in 5 bins of width 1.8: two values per bin (the maximum lands in the last bin).
  std::vector<double> values{0, 1, 2, 3, 4, 5, 6, 7, 8, 9, std::nan(""), INFINITY};
  plot.setHistogram(values, 5, Qt::blue);
  EXPECT_EQ(plot.mode(), PlotWidget::Mode::Histogram);
  ASSERT_EQ(plot.histogramCounts().size(), 5u);
  for (int c : plot.histogramCounts()) EXPECT_EQ(c, 2);
}

TEST(PlotWidget, ConstantSampleStillGivesOneBar) {
  mrsns::test::guiApp();
  PlotWidget plot;
  plot.setHistogram({3.0, 3.0, 3.0}, 4, Qt::blue);
  const auto& counts = plot.histogramCounts();
  EXPECT_EQ(std::accumulate(counts.begin(), counts.end(), 0), 3);
  plot.setHistogram({std::nan("")}, 4, Qt::blue);
  EXPECT_TRUE(plot.histogramCounts().empty());
}

TEST(PlotWidget, SeriesReplaceByNameAndAppendKeepsTheNewest) {
  mrsns::test::guiApp();
  PlotWidget plot;
  plot.setSeries("a", {0, 1, 2}, {1, 2, 3}, Qt::red);
  plot.setSeries("a", {0, 1}, {1, 2, 99}, Qt::red);  // y longer than x: truncated to x
  EXPECT_EQ(plot.seriesCount(), 1);
  EXPECT_EQ(plot.pointCount(), 2u);
  for (int i = 0; i < 10; ++i) plot.appendPoint("live", i, i * i, Qt::green, 4);
  EXPECT_EQ(plot.seriesCount(), 2);
  EXPECT_EQ(plot.pointCount(), 2u + 4u);
  plot.clear();
  EXPECT_EQ(plot.pointCount(), 0u);
}

TEST(PlotWidget, DrawsTheCurveAndSurvivesDegenerateData) {
  mrsns::test::guiApp();
  PlotWidget plot;
  plot.resize(300, 200);
  plot.setTitle("residuals");
  const QImage empty = plot.grab().toImage();
  plot.setSeries("r", {0, 1, 2, 3}, {0.5, 0.7, std::nan(""), 0.6}, QColor(255, 0, 0));
  plot.setThreshold(1.0, "limit");
  const QImage drawn = plot.grab().toImage();
  // Some pure-ish red pixels exist only once the series is drawn.
  auto redPixels = [](const QImage& image) {
    int n = 0;
    for (int y = 0; y < image.height(); ++y)
      for (int x = 0; x < image.width(); ++x) {
        const QColor c = image.pixelColor(x, y);
        if (c.red() > 200 && c.green() < 60 && c.blue() < 60) ++n;
      }
    return n;
  };
  EXPECT_EQ(redPixels(empty), 0);
  EXPECT_GT(redPixels(drawn), 20);
  // A single point and an all-NaN series must paint without dividing by zero.
  plot.setSeries("r", {1}, {1}, Qt::red);
  plot.setSeries("n", {std::nan("")}, {std::nan("")}, Qt::red);
  EXPECT_FALSE(plot.grab().isNull());
}
