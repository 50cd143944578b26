// The fleet filter bar (time range, firmware, parameter set), kept in the URL's hash query.
import { getJson } from '../api.js';
import { dateToMs, h } from '../ui.js';

export async function filterBar(query, onApply, { parameterSet = true } = {}) {
  const meta = await getJson('/api/meta');
  const option = (value, label, selected) => h('option', { value, selected: value === selected }, label);
  const set = query.get('parameter_set') || meta.default_parameter_set;
  const form = h('form', { class: 'filters', 'data-testid': 'filters' },
    h('label', {}, 'From', h('input', { type: 'date', name: 'from', value: query.get('from') || '' })),
    h('label', {}, 'To (inclusive)', h('input', { type: 'date', name: 'to', value: query.get('to') || '' })),
    h('label', {}, 'Firmware', h('select', { name: 'firmware' }, option('', 'all', query.get('firmware') || ''),
      meta.firmware.map((f) => option(f, f, query.get('firmware') || '')))),
    parameterSet ? h('label', {}, 'Parameter set', h('select', { name: 'parameter_set' },
      meta.parameter_sets.map((s) => option(s, s, set)))) : null,
    h('button', { type: 'submit' }, 'Apply'));
  form.addEventListener('submit', (event) => {
    event.preventDefault();
    const values = new URLSearchParams();
    for (const element of form.querySelectorAll('[name]')) if (element.value) values.set(element.name, element.value);
    onApply(values);
  });
  return { form, meta, set };
}

/// The API's filter parameters from the hash query.
export function apiFilter(query, meta) {
  return {
    from_ms: dateToMs(query.get('from')),
    to_ms: dateToMs(query.get('to'), true),
    firmware: query.get('firmware') || '',
    parameter_set: query.get('parameter_set') || (meta ? meta.default_parameter_set : ''),
  };
}
