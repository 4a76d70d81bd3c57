#pragma once
// A small QPainter plot: line series over x (residuals per frame, error over
// time) or a histogram (latency), with axes, a title and optional threshold
// line. No QtCharts: the workstation only needs to be read at a glance.
#include <QColor>
#include <QString>
#include <QWidget>
#include <optional>
#include <vector>

namespace mrsns::gui {

class PlotWidget : public QWidget {
  Q_OBJECT
 public:
  enum class Mode { Lines, Histogram };

  explicit PlotWidget(QWidget* parent = nullptr);

  void setTitle(const QString& title);
  void setAxisLabels(const QString& x_label, const QString& y_label);
  /// Replaces the line series of this name (x and y of equal length; NaN
  /// points are skipped). Switches to Lines mode.
  void setSeries(const QString& name, const std::vector<double>& x, const std::vector<double>& y, QColor color);
  /// Appends one point to a series (creates it), keeping at most `max_points`.
  void appendPoint(const QString& name, double x, double y, QColor color, std::size_t max_points = 2000);
  /// Shows a histogram of `values` in `bins` equal bins. Switches to Histogram mode.
  void setHistogram(const std::vector<double>& values, int bins, QColor color);
  /// A horizontal line (Lines) or vertical line (Histogram) at a limit, e.g. a tolerance.
  void setThreshold(std::optional<double> value, const QString& label = {});
  void clear();

  [[nodiscard]] Mode mode() const { return mode_; }
  [[nodiscard]] int seriesCount() const { return static_cast<int>(series_.size()); }
  [[nodiscard]] std::size_t pointCount() const;
  [[nodiscard]] const std::vector<int>& histogramCounts() const { return counts_; }
  [[nodiscard]] QString title() const { return title_; }

  QSize sizeHint() const override { return {320, 180}; }
  QSize minimumSizeHint() const override { return {160, 100}; }

 protected:
  void paintEvent(QPaintEvent* event) override;

 private:
  struct Series {
    QString name;
    std::vector<double> x, y;
    QColor color;
  };
  struct Range {
    double lo = 0.0, hi = 1.0;
  };
  void dataRanges(Range& x, Range& y) const;

  Mode mode_ = Mode::Lines;
  QString title_, x_label_, y_label_;
  std::vector<Series> series_;
  std::vector<int> counts_;
  double hist_lo_ = 0.0, hist_hi_ = 1.0;
  QColor hist_color_;
  std::optional<double> threshold_;
  QString threshold_label_;
};

}  // namespace mrsns::gui
