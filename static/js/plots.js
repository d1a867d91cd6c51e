import uPlot from 'uplot';
import { displayScale, displayUnit } from './units.js';

const WINDOW_S = 10;
const CAPACITY = 600; // samples per robot: 10 s at up to 55 samples/s
const MIN_SPACING_MS = 18; // faster sources are thinned: a 300 px plot shows no more
const MAX_GAP_MS = 50; // at least 20 redraws a second
const NEAR_LIMIT = 0.05; // share of the range that counts as "near a limit"
const PLOT_HEIGHT = 50;

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

function limitsOf( joint, scale ) {

	return joint.limits ? [ joint.limits[ 0 ] * scale, joint.limits[ 1 ] * scale ] : null;

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
 * One small uPlot chart per joint of the selected robot: the last 10 s, the
 * limits drawn, redrawn at least 20 times a second from the robot's
 * JointHistory. The charts' data arrays are allocated once and refilled in place.
 *
 * Redraws are driven by the animation loop, not a timer: a page busy rendering
 * runs timers late (15 a second where 25 were asked for), while the loop knows
 * when the next frame comes and redraws whenever waiting for it would leave a
 * gap over 50 ms.
 */
class JointPlots {

	constructor( container ) {

		this.container = container;
		this.history = null;
		this.color = '#2f6fd6';
		this._plots = []; // { plot, xs, ys }
		this._last = - Infinity; // when the charts were last redrawn (animation clock, ms)
		this._frameMs = 16.7; // the animation loop's frame interval, smoothed
		this._tickAt = null;
		this.redraws = 0; // for tests: the plots are live
		this.redrawMs = 0; // main-thread time of one redraw of every chart, smoothed

	}

	/** Show `history` (a JointHistory, or null for nothing). */
	show( history, color ) {

		this._destroy();
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
		history.joints.forEach( ( joint, j ) => {

			const limits = limitsOf( joint, history.scales[ j ] );
			const row = document.createElement( 'figure' );
			row.className = 'plot';
			const caption = document.createElement( 'figcaption' );
			caption.textContent = `${joint.name} (${displayUnit( joint )})`;
			row.append( caption );
			this.container.append( row );
			const xs = new Array( CAPACITY ).fill( - WINDOW_S );
			const ys = new Array( CAPACITY ).fill( null );
			const pad = limits ? ( limits[ 1 ] - limits[ 0 ] ) * 0.06 : 0;
			const plot = new uPlot( {
				width,
				height: PLOT_HEIGHT,
				legend: { show: false },
				cursor: { show: false },
				select: { show: false },
				scales: {
					x: { time: false, range: [ - WINDOW_S, 0 ] },
					y: limits ? { range: [ limits[ 0 ] - pad, limits[ 1 ] + pad ] } : { auto: true },
				},
				axes: [
					{ show: j === history.joints.length - 1, stroke: colors.axis, size: 22, font: '10px system-ui', grid: { stroke: colors.grid, width: 1 }, ticks: { show: false } },
					{ stroke: colors.axis, size: 40, font: '10px system-ui', grid: { stroke: colors.grid, width: 1 }, ticks: { show: false }, splits: limits ? () => limits : undefined },
				],
				series: [ {}, { stroke: color, width: 1.5, points: { show: false }, spanGaps: false } ],
				plugins: [ limitsPlugin( limits, colors ) ],
			}, [ xs, ys ], row );
			plot.root.setAttribute( 'aria-label', `plot of ${joint.name} over the last ${WINDOW_S} s` );
			this._plots.push( { plot, xs, ys } );

		} );

	}

	/** Call once per animation frame (`time`: the loop's clock, ms); redraws when due. */
	tick( time ) {

		if ( this._tickAt !== null ) this._frameMs += 0.1 * ( Math.min( time - this._tickAt, 200 ) - this._frameMs );
		this._tickAt = time;
		if ( time - this._last + this._frameMs <= MAX_GAP_MS ) return;
		this._last = time;
		this.redraw();

	}

	/** Refill every chart from the history and redraw (20 times a second while shown). */
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
		for ( const [ j, { plot, xs, ys } ] of this._plots.entries() ) {

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

			}
			plot.setData( [ xs, ys ], false );
			plot.redraw( false, false );

		}
		this.redraws ++;
		this.redrawMs += 0.1 * ( performance.now() - started - this.redrawMs );

	}

	/** Width follows the panel. */
	resize() {

		const width = Math.max( 160, this.container.clientWidth || 280 );
		for ( const { plot } of this._plots ) plot.setSize( { width, height: PLOT_HEIGHT } );

	}

	_destroy() {

		for ( const { plot } of this._plots ) plot.destroy();
		this._plots = [];
		this.container.replaceChildren();

	}

	dispose() {

		this._destroy();
		this.history = null;

	}

}

export { CAPACITY as PLOT_CAPACITY, JointHistory, JointPlots, NEAR_LIMIT };
