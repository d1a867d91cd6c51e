import * as THREE from 'three';

const CAPACITY = 4096; // points: 60 s at 50 samples/s fits
const MIN_STEP_M = 0.0005; // a TCP at rest adds no points

/**
 * The TCP's path over the last `seconds`, as a line in the robot's base frame.
 * A ring buffer written twice (at i and i + CAPACITY), so the visible points are
 * always one contiguous draw range: no copying, a fixed amount of memory, and
 * only the two written points are uploaded per sample.
 */
class Trail {

	constructor( color ) {

		this.seconds = 5;
		this._times = new Float64Array( CAPACITY ); // ms, page clock
		this._positions = new Float32Array( 2 * CAPACITY * 3 );
		this._count = 0; // points written so far (monotonic)
		this._first = 0; // oldest point still shown (monotonic index)
		this._last = new THREE.Vector3( Infinity, Infinity, Infinity );

		this.geometry = new THREE.BufferGeometry();
		this._attribute = new THREE.BufferAttribute( this._positions, 3 );
		this._attribute.setUsage( THREE.DynamicDrawUsage );
		this._wholeBuffer = false;
		this._attribute.onUpload( () => {

			this._wholeBuffer = false;

		} );
		this.geometry.setAttribute( 'position', this._attribute );
		this.geometry.setDrawRange( 0, 0 );
		this.material = new THREE.LineBasicMaterial( { color, transparent: true, opacity: 0.85, depthWrite: false } );
		this.line = new THREE.Line( this.geometry, this.material );
		this.line.name = 'trail';
		this.line.frustumCulled = false; // the bounding sphere would have to follow every point
		this.line.renderOrder = 5;

	}

	/** Add the TCP position (base frame, m) seen at `timeMs`. */
	add( x, y, z, timeMs ) {

		if ( Math.abs( x - this._last.x ) + Math.abs( y - this._last.y ) + Math.abs( z - this._last.z ) < MIN_STEP_M ) {

			this._times[ ( this._count - 1 ) % CAPACITY ] = timeMs; // still here: keep it fresh
			return;

		}
		this._last.set( x, y, z );
		const slot = this._count % CAPACITY;
		this._times[ slot ] = timeMs;
		// While the line is hidden nothing is uploaded and ranges would pile up:
		// past a few, upload the whole buffer once instead (no ranges = all of it).
		if ( ! this._wholeBuffer && this._attribute.updateRanges.length >= 64 ) {

			this._attribute.clearUpdateRanges();
			this._wholeBuffer = true;

		}
		for ( const at of [ slot, slot + CAPACITY ] ) {

			this._positions[ 3 * at ] = x;
			this._positions[ 3 * at + 1 ] = y;
			this._positions[ 3 * at + 2 ] = z;
			if ( ! this._wholeBuffer ) this._attribute.addUpdateRange( 3 * at, 3 );

		}
		this._attribute.needsUpdate = true;
		this._count ++;

	}

	/** Drop points older than `seconds` before `nowMs` and set the draw range. */
	update( nowMs ) {

		const oldest = nowMs - this.seconds * 1000;
		this._first = Math.max( this._first, this._count - CAPACITY );
		while ( this._first < this._count - 1 && this._times[ this._first % CAPACITY ] < oldest ) this._first ++;
		const shown = this._count - this._first;
		this.geometry.setDrawRange( this._first % CAPACITY, shown >= 2 ? shown : 0 );

	}

	/** The points drawn now, oldest first: [ x, y, z ] in the base frame (m), for tests. */
	points() {

		const { start, count } = this.geometry.drawRange;
		const out = [];
		for ( let i = start; i < start + count; i ++ ) out.push( Array.from( this._positions.subarray( 3 * i, 3 * i + 3 ) ) );
		return out;

	}

	/** Points drawn now (for tests: the buffer never grows). */
	get length() {

		return this.geometry.drawRange.count;

	}

	clear() {

		this._first = this._count;
		this._last.set( Infinity, Infinity, Infinity );
		this.geometry.setDrawRange( 0, 0 );

	}

	dispose() {

		this.line.removeFromParent();
		this.geometry.dispose();
		this.material.dispose();

	}

}

export { CAPACITY as TRAIL_CAPACITY, Trail };
