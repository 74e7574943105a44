//! Plots (SVG) for the reports.
