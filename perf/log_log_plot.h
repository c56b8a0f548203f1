// DrawLogLogPng: one PNG figure of several series on log-log axes, drawn with
// PLplot's pngcairo driver (900 x 600, white background, black axes), each
// series a line through its points with a filled-circle marker and a legend
// row at the top left. Values are already log10; the y axis spans
// [floor(min y) - 0.2, ceil(max y) + 0.2], the x axis [xmin - 0.2, xmax + 0.2].
// Shared by the scaling and initialization plots (perf/scaling.cmake).
#pragma once

#include <map>
#include <string>
#include <vector>

namespace graphslam::perf {

struct LogLogSeries {
  std::string label;
  int red = 0, green = 0, blue = 0;  // its colour
  std::vector<double> x, y;          // log10 values
};

struct LogLogFigure {
  std::string title, x_label, y_label;
  double xmin = 0, xmax = 0;  // log10 range of the x axis before the margin
  std::vector<LogLogSeries> series;
};

// The least-squares slope of y against x (the exponent b of y = a x^b when
// x and y are log10 values).
double LeastSquaresSlope(const std::vector<double>& x, const std::vector<double>& y);

// The command line `NAME CSV PNG` of a plot program: the CSV's columns by
// header name into *columns (*rows rows). 0, or the exit code after a message
// on stderr (1: usage, 2: an empty file).
int ReadPlotCsv(int argc, char** argv, const char* name,
                std::map<std::string, std::vector<double>>* columns, int* rows);

// Writes `figure` to the PNG file `path` (PLplot reports its own errors).
void DrawLogLogPng(const char* path, const LogLogFigure& figure);

}  // namespace graphslam::perf
