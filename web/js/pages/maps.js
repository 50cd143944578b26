// Maps: robots with their map history in brief (versions, the current one, the newest and its review state,
// open findings, versions waiting for review), a page at a time in robot-id order; a row opens the robot's
// history. "Waiting for review" lists only robots with a version an engineer has still to approve or reject.
import { getJson } from '../api.js';
import { card, emptyState, go, h, num, setState } from '../ui.js';
import { historyHash } from '../maphistory.js';

const PAGE_SIZE = 50;

export async function render(main, { query, isCurrent }) {
  const pendingOnly = query.get('pending') === '1';
  const after = query.get('after') || '';
  const page = await getJson('/api/robots', { limit: PAGE_SIZE, after, pending: pendingOnly ? 1 : undefined });
  if (!isCurrent()) return;
  const { robots } = page;
  const address = (changes) => {
    const next = new URLSearchParams(query);
    for (const [key, value] of Object.entries(changes)) {
      if (value) next.set(key, value); else next.delete(key);
    }
    return next.toString() ? `#/maps?${next}` : '#/maps';
  };
  const filter = h('label', { class: 'inline' },
    h('input', { type: 'checkbox', 'data-testid': 'pending-only', checked: pendingOnly,
      onchange: (event) => { go(address({ pending: event.target.checked ? '1' : '', after: '' })); } }),
    ' only robots with a version waiting for review');
  main.append(h('h1', {}, 'Maps'),
    h('p', { class: 'muted' }, 'Each robot\'s map history: uploads, repairs, rollbacks and undos. Robots get the current version (the newest approved one); repairs wait for an engineer\'s review.'),
    h('div', { class: 'filters' }, filter));
  if (robots.length === 0) {
    const message = after ? 'No more robots.' : pendingOnly ? 'No robot has a version waiting for review.' : 'No robots yet.';
    main.append(emptyState(message, after || pendingOnly ? '' : 'A robot appears with its first upload (fleetsim --upload …).'));
    setState(main, 'empty');
    return;
  }
  const rows = robots.map((robot) => h('tr', { class: 'clickable', 'data-testid': 'robot-row', 'data-robot': robot.robot_id,
    onclick: () => { go(historyHash(robot.robot_id)); } },
  h('td', {}, h('a', { href: historyHash(robot.robot_id) }, robot.robot_id)),
  h('td', {}, robot.robot_model), h('td', {}, robot.firmware),
  h('td', { class: 'num' }, num(robot.versions)),
  h('td', { class: 'num' }, robot.current_version ? `v${robot.current_version}` : 'none'),
  h('td', {}, robot.head_version ? [`v${robot.head_version} `, h('span', { class: `badge ${robot.head_version === robot.current_version ? 'current' : robot.head_approval}` }, robot.head_approval)] : '—'),
  h('td', { class: 'num' }, robot.open_findings === undefined ? '—' : num(robot.open_findings)),
  h('td', { class: 'num' }, robot.pending ? h('span', { class: 'badge pending' }, robot.pending) : '0')));
  const title = pendingOnly ? `Robots waiting for review (${num(page.total)})` : `Robots (${num(page.total)})`;
  main.append(card(title, h('table', { 'data-testid': 'robots-table' },
    h('tr', {}, ['robot', 'model', 'firmware', 'versions', 'current', 'newest (review)', 'open findings (newest)', 'pending review']
      .map((t, i) => h('th', { class: i >= 3 && i !== 5 ? 'num' : undefined }, t))),
    rows)));
  const pager = h('div', { class: 'pager' });
  if (after) pager.append(h('button', { class: 'secondary', onclick: () => { go(address({ after: '' })); } }, '⟨ First page'));
  if (page.next) pager.append(h('button', { 'data-testid': 'next-page', onclick: () => { go(address({ after: page.next.after })); } }, 'Next page ⟩'));
  pager.append(h('span', { class: 'muted' }, `${robots.length} robots on this page, by robot id`));
  main.append(pager);
  setState(main, 'ready');
}
