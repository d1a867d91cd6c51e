import uPlot from 'uplot';
import { displayScale, displayUnit } from './units.js';

const WINDOW_S = 10;
const CAPACITY = 600; // samples per robot: 10 s at up to 55 samples/s
const MIN_SPACING_MS = 18; // faster sources are thinned: a 300 px plot shows no more
const NEAR_LIMIT = 0.05; // share of the range that counts as "near a limit"
const PLOT_HEIGHT = 66; // px of drawing area per joint (axes and padding come on top)
const MANY_PLOTS = 12; // more joints than this: the plots can be filtered by joint name
const MIN_SPAN = 2; // a still joint gets +-1 deg (or mm) of range, not a flat line at a tick
const REACH = 0.5; // a limit within this share of the data's span is brought into view
const ENLARGED_MIN = 4 * PLOT_HEIGHT; // an enlarged plot is at least this tall (drawing area, px)
const ENLARGED_SPARE = 90; // px of the panel left to the heading, caption and time axis

/**
 * The last WINDOW_S seconds of one robot's joints, in a ring buffer: a fixed
 * amount of memory however long the page runs. Times are the samples' own
 * (t_source, ms on the data layer's clock), so frames a busy page received in
 * one burst still sit where they were sampled; "now" is the newest sample's
 * time plus how long ago it arrived, so a device clock that is off does not
 * shift the window. Values in display units (deg, mm).
 */
class JointHistory {

	constructor( joints ) {

		this.joints = joints;
		this.scales = joints.map( displayScale );
		this.times = new Float64Array( CAPACITY ); // ms, the samples' clock (t_source)
		this.arrivalMs = 0; // page clock, when the newest sample arrived
		this.values = new Float64Array( CAPACITY * joints.length );
		this.count = 0; // samples written so far (monotonic)

	}

	/** Record joint values (SI, hello order) sampled at `timeMs` (t_source, ms) arriving at `arrivalMs`. */
	add( values, timeMs, arrivalMs ) {

		this.arrivalMs = arrivalMs;
		if ( this.count > 0 && timeMs - this.times[ ( this.count - 1 ) % CAPACITY ] < MIN_SPACING_MS ) return;
		const slot = this.count % CAPACITY;
		this.times[ slot ] = timeMs;
		const n = this.joints.length;
		for ( let j = 0; j < n; j ++ ) this.values[ slot * n + j ] = j < values.length ? values[ j ] * this.scales[ j ] : NaN;
		this.count ++;

	}

}

// Chromium rasterises a 2D canvas on the GPU where it can. Without a GPU that is
// SwiftShader in the GPU process, where seven charts redrawn 15 times a second cost
// more than the 3D view itself (10 -> 20 frames/s with them stopped, Chromium's
// default path, at the lowest quality level). `willReadFrequently` keeps a canvas on the CPU: drawn by Skia
// here, handed over as a bitmap. uPlot asks for its context in its constructor,
// so the option is slipped in around that call.
function onCpuCanvas( make ) {

	const getContext = HTMLCanvasElement.prototype.getContext;
	HTMLCanvasElement.prototype.getContext = function ( kind, options ) {

		return getContext.call( this, kind, kind === '2d' ? { ...options, willReadFrequently: true } : options );

	};
	try {

		return make();

	} finally {

		HTMLCanvasElement.prototype.getContext = getContext;

	}

}

function limitsOf( joint, scale ) {

	return joint.limits ? [ joint.limits[ 0 ] * scale, joint.limits[ 1 ] * scale ] : null;

}

/**
 * The y range for one joint's window: its data, padded, at least MIN_SPAN wide,
 * widened to a limit that is within REACH of it so an approach is seen coming.
 * `current` is kept while the data fit in it and fill a third of it, so the axis
 * does not twitch at every redraw.
 */
function fitRange( lo, hi, limits, current ) {

	if ( ! Number.isFinite( lo ) ) return current;
	const span = Math.max( hi - lo, MIN_SPAN );
	if ( current && lo >= current[ 0 ] && hi <= current[ 1 ] && span * 3 >= current[ 1 ] - current[ 0 ] ) return current;
	const mid = ( lo + hi ) / 2;
	let min = Math.min( lo, mid - span / 2 ) - span * 0.15;
	let max = Math.max( hi, mid + span / 2 ) + span * 0.15;
	if ( limits ) {

		if ( lo - limits[ 0 ] <= span * REACH ) min = Math.min( min, limits[ 0 ] - span * 0.1 );
		if ( limits[ 1 ] - hi <= span * REACH ) max = Math.max( max, limits[ 1 ] + span * 0.1 );

	}
	return [ min, max ];

}

// Limits as dashed lines and the last NEAR_LIMIT of the range on each side shaded amber.
function limitsPlugin( limits, colors ) {

	return {
		hooks: {
			drawClear: ( u ) => {

				if ( ! limits ) return;
				const { ctx } = u;
				const { left, width } = u.bbox;
				const band = ( limits[ 1 ] - limits[ 0 ] ) * NEAR_LIMIT;
				ctx.save();
				// Only the limits within the fitted range: clipped to the drawing area.
				ctx.beginPath();
				ctx.rect( left, u.bbox.top, width, u.bbox.height );
				ctx.clip();
				ctx.fillStyle = colors.near;
				for ( const [ a, b ] of [ [ limits[ 0 ], limits[ 0 ] + band ], [ limits[ 1 ] - band, limits[ 1 ] ] ] ) {

					const y0 = u.valToPos( a, 'y', true );
					const y1 = u.valToPos( b, 'y', true );
					ctx.fillRect( left, Math.min( y0, y1 ), width, Math.abs( y1 - y0 ) );

				}
				ctx.strokeStyle = colors.limit;
				ctx.lineWidth = 1 * uPlot.pxRatio;
				ctx.setLineDash( [ 4 * uPlot.pxRatio, 3 * uPlot.pxRatio ] );
				ctx.beginPath();
				for ( const value of limits ) {

					const y = Math.round( u.valToPos( value, 'y', true ) ) + 0.5;
					ctx.moveTo( left, y );
					ctx.lineTo( left + width, y );

				}
				ctx.stroke();
				ctx.restore();

			},
		},
	};

}

/**
 * Velocities (display units per s) of one joint between consecutive samples
 * `ys` at times `xs` (s), into `vs`: a finite difference of what the plot
 * already holds, null where either sample is missing. Returns [min, max].
 */
function differentiate( xs, ys, vs ) {

	let lo = Infinity;
	let hi = - Infinity;
	vs[ 0 ] = null;
	for ( let i = 1; i < ys.length; i ++ ) {

		const dt = xs[ i ] - xs[ i - 1 ];
		if ( ys[ i ] === null || ys[ i - 1 ] === null || ! ( dt > 0 ) ) {

			vs[ i ] = null;
			continue;

		}
		const v = ( ys[ i ] - ys[ i - 1 ] ) / dt;
		vs[ i ] = v;
		lo = Math.min( lo, v );
		hi = Math.max( hi, v );

	}
	return [ lo, hi ];

}

/**
 * One small uPlot chart per joint of the selected robot: the last 10 s, the
 * limits drawn, redrawn from the robot's JointHistory by the app's readout tick
 * (in the animation loop, with the other readouts: a timer runs late on a page
 * busy rendering). The charts' data arrays are allocated once and refilled in place.
 * Optionally each also shows the joint's velocity (dashed, its own axis on the
 * right), and one joint's chart can be enlarged to the panel's height.
 */
class JointPlots {

	constructor( container, velocityToggle = null, filterInput = null ) {

		this.container = container;
		// Many joints (a humanoid): a search field picks the plots by joint name.
		this.filterInput = filterInput;
		this.filter = '';
		filterInput?.addEventListener( 'input', () => {

			this.filter = filterInput.value.trim().toLowerCase();
			this.show( this.history, this.color );

		} );
		this.velocity = velocityToggle ? velocityToggle.checked : false; // velocity traces shown
		this.enlarged = null; // the joint whose chart fills the panel, or null: all of them
		velocityToggle?.addEventListener( 'change', () => {

			this.velocity = velocityToggle.checked;
			this.show( this.history, this.color );

		} );
		this.history = null;
		this.color = '#2f6fd6';
		this._plots = []; // { plot, xs, ys, limits, range }
		this.redraws = 0; // for tests: the plots are live
		this.redrawMs = 0; // main-thread time of one redraw of every chart, smoothed

	}

	/** Show `history` (a JointHistory, or null for nothing). */
	show( history, color ) {

		this._destroy();
		if ( history !== this.history ) this.enlarged = null;
		this.history = history;
		this.color = color;
		if ( ! history ) return;
		const style = getComputedStyle( document.documentElement );
		const colors = {
			axis: style.getPropertyValue( '--muted' ).trim() || '#6b7482',
			grid: style.getPropertyValue( '--line' ).trim() || 'rgba(0,0,0,0.1)',
			limit: style.getPropertyValue( '--bad' ).trim() || '#d6352b',
			near: 'rgba(217, 138, 0, 0.16)',
		};
		const width = Math.max( 160, this.container.clientWidth || 280 );
		if ( this.filterInput ) this.filterInput.hidden = history.joints.length <= MANY_PLOTS;
		const wanted = ( joint ) => this.filter === '' || joint.name.toLowerCase().includes( this.filter );
		const shown = this.enlarged === null
			? history.joints.flatMap( ( joint, j ) => ( wanted( joint ) ? [ j ] : [] ) )
			: [ this.enlarged ];
		const height = this.enlarged === null ? PLOT_HEIGHT : this._enlargedHeight();
		for ( const j of shown ) {

			const joint = history.joints[ j ];
			const unit = displayUnit( joint );
			const limits = limitsOf( joint, history.scales[ j ] );
			const row = document.createElement( 'figure' );
			row.className = 'plot';
			const caption = document.createElement( 'figcaption' );
			const title = document.createElement( 'span' );
			title.className = 'plot-title';
			title.textContent = `${joint.name} (${unit})${this.velocity ? ` · velocity (${unit}/s, dashed)` : ''}`;
			caption.append( title );
			const enlarge = document.createElement( 'button' );
			enlarge.type = 'button';
			enlarge.className = 'plot-size';
			enlarge.textContent = this.enlarged === null ? '⤢' : '⤡';
			enlarge.title = this.enlarged === null ? `enlarge the plot of ${joint.name}` : 'back to every joint\'s plot';
			enlarge.setAttribute( 'aria-label', enlarge.title );
			enlarge.addEventListener( 'click', () => this.enlarge( this.enlarged === null ? j : null ) );
			caption.append( enlarge );
			row.append( caption );
			this.container.append( row );
			const xs = new Array( CAPACITY ).fill( - WINDOW_S );
			const ys = new Array( CAPACITY ).fill( null );
			const vs = this.velocity ? new Array( CAPACITY ).fill( null ) : null;
			const last = j === shown[ shown.length - 1 ];
			const grid = { stroke: colors.grid, width: 1 };
			const numbers = ( u, splits ) => splits.map( ( v ) => `${+ v.toFixed( 2 )}` );
			const axes = [
				{ show: last, stroke: colors.axis, size: 18, label: 'time (s)', labelSize: 12, labelFont: '10px system-ui', font: '10px system-ui', grid, ticks: { show: false } },
				{ stroke: colors.axis, size: 44, space: 18, font: '10px system-ui', grid, ticks: { show: false }, values: numbers },
			];
			const series = [ {}, { stroke: color, width: 1.5, points: { show: false }, spanGaps: false } ];
			const scales = {
				x: { time: false, range: [ - WINDOW_S, 0 ] },
				y: { auto: false, range: [ - 1, 1 ] }, // fitted to the window in redraw()
			};
			if ( vs ) {

				// Its own scale and axis (right): a velocity is not read against the position's ticks.
				scales.v = { auto: false, range: [ - 1, 1 ] };
				axes.push( { scale: 'v', side: 1, stroke: colors.axis, size: 40, space: 18, font: '10px system-ui', grid: { show: false }, ticks: { show: false }, values: numbers } );
				series.push( { scale: 'v', stroke: color, width: 1, dash: [ 4, 3 ], alpha: 0.8, points: { show: false }, spanGaps: false } );

			}
			// Every plot has the same y-axis widths, so the time axes line up; the last shows them.
			const plot = onCpuCanvas( () => new uPlot( {
				width,
				height,
				legend: { show: false },
				padding: [ 6, vs ? 0 : 6, last ? null : 6, 0 ], // uPlot's automatic padding took half the height
				cursor: { show: false },
				select: { show: false },
				scales,
				axes,
				series,
				plugins: [ limitsPlugin( limits, colors ) ],
			}, vs ? [ xs, ys, vs ] : [ xs, ys ], row ) );
			plot.root.setAttribute( 'aria-label', `plot of ${joint.name} over the last ${WINDOW_S} s` );
			this._plots.push( { plot, joint: j, xs, ys, vs, limits, range: null, vrange: null, height, outer: height, fitted: false } );

		}

	}

	/** Enlarge joint `j`'s chart to the panel's height (null: back to every joint's). */
	enlarge( j ) {

		this.enlarged = j;
		this.show( this.history, this.color );

	}

	_enlargedHeight() {

		// The panel's visible height, less its heading, the caption and the time axis.
		const body = this.container.closest( '.panel-body' );
		return Math.max( ENLARGED_MIN, ( body ? body.clientHeight : 0 ) - ENLARGED_SPARE );

	}

	/** Refill every chart from the history and redraw (the app's readout tick: 10 times a second). */
	redraw() {

		const history = this.history;
		// Collapsed: skip the work (a class test, not offsetParent, which would force a layout).
		if ( ! history || this.container.closest( '.collapsed' ) !== null ) return;
		if ( history.count === 0 ) return;
		const started = performance.now();
		const newest = history.times[ ( history.count - 1 ) % CAPACITY ];
		const nowMs = newest + ( performance.timeOrigin + performance.now() - history.arrivalMs );
		const n = history.joints.length;
		const count = Math.min( history.count, CAPACITY );
		const oldest = nowMs - WINDOW_S * 1000;
		// Chronological copy into the fixed arrays; unused leading slots are gaps at the left edge.
		const lead = CAPACITY - count;
		for ( const entry of this._plots ) {

			const { plot, xs, ys, vs, joint: j } = entry;
			if ( ! entry.fitted && plot.bbox.height > 0 ) {

				// uPlot's height is the whole chart, laid out after a microtask: once it is,
				// add back what the axes and padding took from the drawing area.
				entry.fitted = true;
				entry.outer += entry.height - plot.bbox.height / uPlot.pxRatio;
				plot.setSize( { width: plot.width, height: entry.outer } );

			}
			let lo = Infinity;
			let hi = - Infinity;

			for ( let i = 0; i < lead; i ++ ) {

				xs[ i ] = - WINDOW_S;
				ys[ i ] = null;

			}
			for ( let k = 0; k < count; k ++ ) {

				const slot = ( history.count - count + k ) % CAPACITY;
				const t = history.times[ slot ];
				const at = lead + k;
				xs[ at ] = Math.max( ( t - nowMs ) / 1000, - WINDOW_S );
				const value = history.values[ slot * n + j ];
				ys[ at ] = t < oldest || Number.isNaN( value ) ? null : value;
				if ( ys[ at ] !== null ) {

					lo = Math.min( lo, value );
					hi = Math.max( hi, value );

				}

			}
			let rescaled = false;
			if ( vs ) {

				const [ vlo, vhi ] = differentiate( xs, ys, vs );
				const vrange = fitRange( vlo, vhi, null, entry.vrange );
				if ( vrange !== entry.vrange ) {

					entry.vrange = vrange;
					plot.setScale( 'v', { min: vrange[ 0 ], max: vrange[ 1 ] } );
					rescaled = true;

				}

			}
			plot.setData( vs ? [ xs, ys, vs ] : [ xs, ys ], false );
			const range = fitRange( lo, hi, entry.limits, entry.range );
			if ( range !== entry.range ) {

				entry.range = range;
				plot.setScale( 'y', { min: range[ 0 ], max: range[ 1 ] } ); // redraws

			} else if ( ! rescaled ) plot.redraw( false, false );

		}
		this.redraws ++;
		this.redrawMs += 0.1 * ( performance.now() - started - this.redrawMs );

	}

	/** Width follows the panel. */
	resize() {

		const width = Math.max( 160, this.container.clientWidth || 280 );
		for ( const { plot, outer } of this._plots ) plot.setSize( { width, height: outer } );

	}

	_destroy() {

		for ( const { plot } of this._plots ) plot.destroy();
		this._plots = [];
		this.container.replaceChildren();

	}

	/** For tests: each plot's drawing height (CSS px), y range and limits, in display units. */
	layout() {

		const range = ( values ) => {

			const drawn = values ? values.filter( ( v ) => v !== null ) : [];
			return drawn.length ? [ Math.min( ...drawn ), Math.max( ...drawn ) ] : null;

		};
		return this._plots.map( ( { plot, limits, ys, vs, joint } ) => ( {
			joint,
			traces: plot.series.length - 1,
			velocity: range( vs ),
			data: [ Math.min( ...ys.filter( ( v ) => v !== null ) ), Math.max( ...ys.filter( ( v ) => v !== null ) ) ],
			height: plot.bbox.height / uPlot.pxRatio,
			left: plot.bbox.left / uPlot.pxRatio,
			y: [ plot.scales.y.min, plot.scales.y.max ],
			limits,
		} ) );

	}

	dispose() {

		this._destroy();
		this.history = null;

	}

}

export { CAPACITY as PLOT_CAPACITY, JointHistory, JointPlots, NEAR_LIMIT };
