// Chart.js wrappers (window.Chart from /static/vendor/chart.js/chart.umd.min.js). No animation: pages render
// once, and the browser tests read the charts right away.
const palette = ['#2f6fdf', '#d64541', '#2e9d5b', '#e0a100', '#7b4fd1', '#1aa3a3', '#e46f1f', '#6b7385'];
export const color = (i) => palette[i % palette.length];
const charts = new Set();

export function destroyAll() {
  for (const chart of charts) chart.destroy();
  charts.clear();
}

function make(canvas, config) {
  if (!window.Chart) throw new Error('Chart.js did not load (web/node_modules missing? run the build: npm ci)');
  config.options = Object.assign({ animation: false, responsive: true, maintainAspectRatio: false }, config.options || {});
  const chart = new window.Chart(canvas, config);
  canvas.dataset.points = String(config.data.datasets.reduce((n, d) => n + d.data.filter((v) => v !== null).length, 0));
  charts.add(chart);
  return chart;
}

const percentAxis = { beginAtZero: true, ticks: { callback: (v) => `${Math.round(v * 100)}%` } };

export function bar(canvas, labels, datasets, { percent = false, stacked = false, horizontal = false } = {}) {
  return make(canvas, {
    type: 'bar',
    data: { labels, datasets: datasets.map((d, i) => ({ backgroundColor: color(i), ...d })) },
    options: {
      indexAxis: horizontal ? 'y' : 'x',
      scales: { x: { stacked }, y: percent ? { ...percentAxis, stacked } : { beginAtZero: true, stacked } },
      plugins: { legend: { display: datasets.length > 1 } },
    },
  });
}

export function line(canvas, labels, datasets, { percent = false, y2 = null } = {}) {
  const scales = { y: percent ? percentAxis : { beginAtZero: true } };
  if (y2) scales.y2 = { position: 'right', beginAtZero: true, grid: { drawOnChartArea: false }, title: { display: true, text: y2 } };
  return make(canvas, {
    type: 'line',
    data: {
      labels,
      datasets: datasets.map((d, i) => ({ borderColor: color(i), backgroundColor: color(i), tension: 0.2, pointRadius: 3, spanGaps: true, ...d })),
    },
    options: { scales, plugins: { legend: { display: true } } },
  });
}

export function doughnut(canvas, labels, data, colors) {
  return make(canvas, {
    type: 'doughnut',
    data: { labels, datasets: [{ data, backgroundColor: colors || labels.map((_, i) => color(i)) }] },
    options: { plugins: { legend: { position: 'right' } } },
  });
}
