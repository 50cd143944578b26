// The dashboard: one page, hash routes, one module per page (pages/). Every page renders into <main> and
// sets main[data-state] to "ready", "empty" or "error" when it is done (the browser tests wait on it).
import { destroyAll } from './charts.js';
import { errorState, setState } from './ui.js';
import { updateTokenStatus } from './api.js';
import * as overview from './pages/overview.js';
import * as runs from './pages/runs.js';
import * as run from './pages/run.js';
import * as experiments from './pages/experiments.js';
import * as labelling from './pages/labelling.js';
import * as jobs from './pages/jobs.js';
import * as maps from './pages/maps.js';
import * as mapHistory from './pages/maphistory.js';
import * as mapVersion from './pages/mapversion.js';

const routes = [
  { pattern: /^\/overview$/, page: overview, nav: 'overview' },
  { pattern: /^\/runs$/, page: runs, nav: 'runs' },
  { pattern: /^\/runs\/([^/]+)$/, page: run, nav: 'runs' },
  { pattern: /^\/experiments$/, page: experiments, nav: 'experiments' },
  { pattern: /^\/labelling$/, page: labelling, nav: 'labelling' },
  { pattern: /^\/jobs$/, page: jobs, nav: 'jobs' },
  { pattern: /^\/maps$/, page: maps, nav: 'maps' },
  { pattern: /^\/robots\/([^/]+)\/maps$/, page: mapHistory, nav: 'maps' },
  { pattern: /^\/robots\/([^/]+)\/maps\/([^/]+)$/, page: mapVersion, nav: 'maps' },
];

let current = null;   // the page module rendered now (its stop() ends timers)
let generation = 0;   // a newer navigation wins over a slow older one

async function navigate() {
  const [path, queryString] = (location.hash.slice(1) || '/overview').split('?');
  const route = routes.find((r) => r.pattern.test(path));
  if (!route) { location.hash = '#/overview'; return; }
  if (current && current.stop) current.stop();
  destroyAll();
  const main = document.getElementById('main');
  main.replaceChildren();
  setState(main, 'loading');
  for (const link of document.querySelectorAll('[data-nav]')) link.classList.toggle('active', link.dataset.nav === route.nav);
  document.body.dataset.page = route.nav;
  current = route.page;
  const mine = ++generation;
  const args = path.match(route.pattern).slice(1).map(decodeURIComponent);
  try {
    await route.page.render(main, { args, query: new URLSearchParams(queryString || ''), isCurrent: () => mine === generation });
  } catch (error) {
    if (mine !== generation) return;
    if (error && error.status) console.warn(error.message); else console.error(error);
    destroyAll();
    main.replaceChildren(errorState(error));
    setState(main, 'error');
  }
}

window.addEventListener('hashchange', navigate);
updateTokenStatus();
navigate();
