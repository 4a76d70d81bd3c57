#include "plot_widget.h"

#include <QPainter>
#include <QPainterPath>
#include <algorithm>
#include <cmath>
#include <limits>

namespace mrsns::gui {
namespace {

// Round axis limits to "nice" numbers so the tick labels are short.
double niceStep(double span, int ticks) {
  const double raw = span / std::max(1, ticks);
  const double magnitude = std::pow(10.0, std::floor(std::log10(raw)));
  const double r = raw / magnitude;
  const double nice = r < 1.5 ? 1.0 : r < 3.0 ? 2.0 : r < 7.0 ? 5.0 : 10.0;
  return nice * magnitude;
}

QString tickText(double v, double step) {
  const int decimals = step >= 1.0 ? 0 : std::min(4, static_cast<int>(std::ceil(-std::log10(step))));
  return QString::number(v, 'f', decimals);
}

}  // namespace

PlotWidget::PlotWidget(QWidget* parent) : QWidget(parent) {
  setAttribute(Qt::WA_OpaquePaintEvent);
  setSizePolicy(QSizePolicy::Expanding, QSizePolicy::Expanding);
}

void PlotWidget::setTitle(const QString& title) {
  title_ = title;
  update();
}

void PlotWidget::setAxisLabels(const QString& x_label, const QString& y_label) {
  x_label_ = x_label;
  y_label_ = y_label;
  update();
}

void PlotWidget::setSeries(const QString& name, const std::vector<double>& x, const std::vector<double>& y,
                           QColor color) {
  mode_ = Mode::Lines;
  const std::size_t n = std::min(x.size(), y.size());
  Series s{name, std::vector<double>(x.begin(), x.begin() + static_cast<std::ptrdiff_t>(n)),
           std::vector<double>(y.begin(), y.begin() + static_cast<std::ptrdiff_t>(n)), color};
  auto it = std::find_if(series_.begin(), series_.end(), [&](const Series& e) { return e.name == name; });
  if (it == series_.end()) {
    series_.push_back(std::move(s));
  } else {
    *it = std::move(s);
  }
  update();
}

void PlotWidget::appendPoint(const QString& name, double x, double y, QColor color, std::size_t max_points) {
  mode_ = Mode::Lines;
  auto it = std::find_if(series_.begin(), series_.end(), [&](const Series& e) { return e.name == name; });
  if (it == series_.end()) {
    series_.push_back(Series{name, {}, {}, color});
    it = std::prev(series_.end());
  }
  it->x.push_back(x);
  it->y.push_back(y);
  if (it->x.size() > max_points) {
    const auto drop = static_cast<std::ptrdiff_t>(it->x.size() - max_points);
    it->x.erase(it->x.begin(), it->x.begin() + drop);
    it->y.erase(it->y.begin(), it->y.begin() + drop);
  }
  update();
}

void PlotWidget::setHistogram(const std::vector<double>& values, int bins, QColor color) {
  mode_ = Mode::Histogram;
  series_.clear();
  hist_color_ = color;
  bins = std::max(1, bins);
  counts_.assign(static_cast<std::size_t>(bins), 0);
  double lo = std::numeric_limits<double>::infinity();
  double hi = -lo;
  for (double v : values) {
    if (!std::isfinite(v)) continue;
    lo = std::min(lo, v);
    hi = std::max(hi, v);
  }
  if (!std::isfinite(lo)) {
    counts_.clear();
    update();
    return;
  }
  if (hi - lo < 1e-12) hi = lo + 1.0;  // a constant sample still gets one visible bar
  hist_lo_ = lo;
  hist_hi_ = hi;
  for (double v : values) {
    if (!std::isfinite(v)) continue;
    auto bin = static_cast<int>((v - lo) / (hi - lo) * bins);
    counts_[static_cast<std::size_t>(std::clamp(bin, 0, bins - 1))]++;
  }
  update();
}

void PlotWidget::setThreshold(std::optional<double> value, const QString& label) {
  threshold_ = value;
  threshold_label_ = label;
  update();
}

void PlotWidget::clear() {
  series_.clear();
  counts_.clear();
  update();
}

std::size_t PlotWidget::pointCount() const {
  std::size_t n = 0;
  for (const auto& s : series_) n += s.x.size();
  return n;
}

void PlotWidget::dataRanges(Range& x, Range& y) const {
  double xlo = std::numeric_limits<double>::infinity(), xhi = -xlo, ylo = xlo, yhi = -xlo;
  if (mode_ == Mode::Histogram) {
    xlo = hist_lo_;
    xhi = hist_hi_;
    ylo = 0.0;
    yhi = counts_.empty() ? 1.0 : *std::max_element(counts_.begin(), counts_.end());
  } else {
    for (const auto& s : series_) {
      for (std::size_t i = 0; i < s.x.size(); ++i) {
        if (!std::isfinite(s.x[i]) || !std::isfinite(s.y[i])) continue;
        xlo = std::min(xlo, s.x[i]);
        xhi = std::max(xhi, s.x[i]);
        ylo = std::min(ylo, s.y[i]);
        yhi = std::max(yhi, s.y[i]);
      }
    }
    if (threshold_) {
      ylo = std::min(ylo, *threshold_);
      yhi = std::max(yhi, *threshold_);
    }
    // Errors and distances read best against zero.
    if (std::isfinite(ylo) && ylo > 0.0) ylo = 0.0;
  }
  if (!std::isfinite(xlo)) xlo = 0.0, xhi = 1.0;
  if (!std::isfinite(ylo)) ylo = 0.0, yhi = 1.0;
  if (xhi - xlo < 1e-12) xhi = xlo + 1.0;
  if (yhi - ylo < 1e-12) yhi = ylo + 1.0;
  x = {xlo, xhi};
  y = {ylo, yhi + 0.05 * (yhi - ylo)};
}

void PlotWidget::paintEvent(QPaintEvent*) {
  QPainter p(this);
  p.setRenderHint(QPainter::Antialiasing);
  const QColor background(0x1e, 0x22, 0x28);
  const QColor grid(0x3a, 0x40, 0x48);
  const QColor text(0xc8, 0xd0, 0xd8);
  p.fillRect(rect(), background);

  const QFontMetrics fm(font());
  const int left = fm.horizontalAdvance(QStringLiteral("00000.0")) + 8;
  const int top = fm.height() + 8;
  const int bottom = 2 * fm.height() + 6;
  const QRect plot(left, top, std::max(10, width() - left - 12), std::max(10, height() - top - bottom));

  p.setPen(text);
  p.drawText(QRect(0, 2, width(), fm.height() + 4), Qt::AlignHCenter | Qt::AlignVCenter, title_);

  const bool empty = mode_ == Mode::Lines ? pointCount() == 0 : counts_.empty();
  if (empty) {
    p.setPen(grid.lighter(160));
    p.drawText(plot, Qt::AlignCenter, tr("no data yet"));
    return;
  }

  Range xr, yr;
  dataRanges(xr, yr);
  auto px = [&](double x) { return plot.left() + (x - xr.lo) / (xr.hi - xr.lo) * plot.width(); };
  auto py = [&](double y) { return plot.bottom() - (y - yr.lo) / (yr.hi - yr.lo) * plot.height(); };

  // Grid and tick labels.
  const double ystep = niceStep(yr.hi - yr.lo, 4);
  for (double v = std::ceil(yr.lo / ystep) * ystep; v <= yr.hi + 1e-9; v += ystep) {
    p.setPen(grid);
    p.drawLine(QPointF(plot.left(), py(v)), QPointF(plot.right(), py(v)));
    p.setPen(text);
    p.drawText(QRectF(0, py(v) - fm.height() / 2.0, left - 4, fm.height()), Qt::AlignRight | Qt::AlignVCenter,
               tickText(v, ystep));
  }
  const double xstep = niceStep(xr.hi - xr.lo, 5);
  for (double v = std::ceil(xr.lo / xstep) * xstep; v <= xr.hi + 1e-9; v += xstep) {
    p.setPen(grid);
    p.drawLine(QPointF(px(v), plot.top()), QPointF(px(v), plot.bottom()));
    p.setPen(text);
    p.drawText(QRectF(px(v) - 40, plot.bottom() + 2, 80, fm.height()), Qt::AlignHCenter, tickText(v, xstep));
  }
  p.drawText(QRect(plot.left(), height() - fm.height() - 2, plot.width(), fm.height()), Qt::AlignHCenter, x_label_);
  if (!y_label_.isEmpty()) {
    p.drawText(QRect(4, 2, left, fm.height() + 4), Qt::AlignLeft | Qt::AlignVCenter, y_label_);
  }
  p.setPen(grid.lighter(140));
  p.drawRect(plot);

  if (mode_ == Mode::Histogram) {
    const double bw = plot.width() / static_cast<double>(counts_.size());
    for (std::size_t i = 0; i < counts_.size(); ++i) {
      const double h = plot.bottom() - py(counts_[i]);
      p.fillRect(QRectF(plot.left() + i * bw + 1, plot.bottom() - h, std::max(1.0, bw - 2), h), hist_color_);
    }
  } else {
    p.setClipRect(plot.adjusted(-1, -1, 1, 1));
    for (const auto& s : series_) {
      QPainterPath path;
      bool pen_down = false;
      for (std::size_t i = 0; i < s.x.size(); ++i) {
        if (!std::isfinite(s.x[i]) || !std::isfinite(s.y[i])) {
          pen_down = false;
          continue;
        }
        const QPointF point(px(s.x[i]), py(s.y[i]));
        if (pen_down) {
          path.lineTo(point);
        } else {
          path.moveTo(point);
          pen_down = true;
        }
      }
      p.setPen(QPen(s.color, 1.6));
      p.drawPath(path);
      if (s.x.size() < 60) {  // markers only where they stay readable
        p.setBrush(s.color);
        for (std::size_t i = 0; i < s.x.size(); ++i) {
          if (std::isfinite(s.x[i]) && std::isfinite(s.y[i])) p.drawEllipse(QPointF(px(s.x[i]), py(s.y[i])), 2.2, 2.2);
        }
        p.setBrush(Qt::NoBrush);
      }
    }
    p.setClipping(false);
    // Legend when there is more than one series.
    if (series_.size() > 1) {
      int y = plot.top() + 4;
      for (const auto& s : series_) {
        p.setPen(s.color);
        p.drawText(QRect(plot.left() + 6, y, plot.width() - 12, fm.height()), Qt::AlignRight, s.name);
        y += fm.height();
      }
    }
  }

  if (threshold_) {
    p.setPen(QPen(QColor(0xe0, 0x6c, 0x4c), 1.2, Qt::DashLine));
    if (mode_ == Mode::Lines) {
      p.drawLine(QPointF(plot.left(), py(*threshold_)), QPointF(plot.right(), py(*threshold_)));
      p.drawText(QPointF(plot.left() + 4, py(*threshold_) - 3), threshold_label_);
    } else {
      p.drawLine(QPointF(px(*threshold_), plot.top()), QPointF(px(*threshold_), plot.bottom()));
      p.drawText(QPointF(px(*threshold_) + 3, plot.top() + fm.height()), threshold_label_);
    }
  }
}

}  // namespace mrsns::gui
