// Exports from the workbench, each through the shell's file browser in save mode (as Save
// project as): a plot's image from its context menu (SVG drawn from the plot's data by
// core/report/figure.h, or PNG: the plot drawn alone offscreen at the size the menu asks for, as
// greybench-snapshot --plot draws it), the estimation report as Markdown or HTML
// (core/report/report.h) and the model file. No export writes onto a file the open project is
// made of (the output guard, core/util/output_guard.h): the refusal and every failure go to the
// Messages window, naming the file.
//
//   every frame, in UpdateShell:  UpdateExports(state);   // a plot's menu asked: the browser
//   the browser's choice:         FinishExport(state, purpose, path);
//   greybench_main, after rendering a frame:
//     if (auto png = TakePendingPng(state)) { an offscreen framebuffer of png->width x height;
//       NewFrame, DrawFigureFrame(state.plots, png->figure), Render, render, glReadPixels;
//       FinishPendingPng(state, *png, &pixels); }
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "ui/state/app_state.h"
#include "ui/state/shell_state.h"

namespace gb::ui {

// Opens the file browser for a plot's export its context menu asked for.
void UpdateExports(AppState& state);

// The file browser chose `path` for an export purpose (kExportPlot, kSaveReport, kExportModel).
void FinishExport(AppState& state, BrowsePurpose purpose, const std::string& path);

// The Estimate view's "Save report…": the report of `fit` (core/report/report.h), Markdown or
// HTML by the name's extension (else by the browser's filter). With `with_residuals`, also the
// residual analysis the Residuals view shows (its dataset, at the parameter values the views
// show: after a fit, its estimates).
void BrowseSaveReport(AppState& state, const FitResult& fit, bool with_residuals);

// File > Export model: the model the views show (with its edits) as a model file.
void BrowseExportModel(AppState& state);
// File > Export > FMU: the model the views show, at the values they show (a fit's estimates and
// delays when the views show a fit of this model, else the model's values), as an FMI 2.0 FMU of
// `interface` (core/fmu/fmu.h). The browser chooses the file (its stem is the model
// identifier); the C compiler builds it off the UI thread, and the Messages window says when it
// is written (with the delays the FMU leaves to the importer), or why not.
// With `virtual_sensor`, the model's filter as a Co-Simulation FMU instead (export-fmu
// --virtual-sensor), with the delays the views show.
void BrowseExportFmu(AppState& state, fmu::Interface interface, bool virtual_sensor = false);
// Takes a finished FMU build (every frame, from UpdateExports); true when one finished.
bool PollFmuExport(AppState& state);
// The File menu's Export submenu.
void DrawExportMenu(AppState& state);

// File › Export › Image of the view: the browser for a PNG of the current view drawn whole at
// width x height pixels (1024 x 768 for a projector), as greybench-snapshot --width --height
// draws it; greybench draws it offscreen after the window's frame (TakePendingViewImage).
void BrowseViewImage(AppState& state, int width, int height);
std::optional<PendingViewImage> TakePendingViewImage(AppState& state);
// Writes the pixels drawn (as FinishPendingPng) and says so in the Messages window.
void FinishPendingViewImage(AppState& state, const PendingViewImage& image,
                            const std::vector<unsigned char>* rgba);

// The PNG a plot's menu asked for, once its file is chosen: taken (and cleared) by the
// application, which draws it offscreen after the window's frame. nullopt when none is due.
std::optional<PendingPng> TakePendingPng(AppState& state);
// Writes the pixels drawn (RGBA, rows from the bottom, as glReadPixels gives them; null when no
// framebuffer could be made) to the PNG file, and says so in the Messages window.
void FinishPendingPng(AppState& state, const PendingPng& png,
                      const std::vector<unsigned char>* rgba);

}  // namespace gb::ui
