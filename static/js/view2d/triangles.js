import * as THREE from 'three';

// The 2D view's solids: triangles projected with the camera's own matrices (three's
// math), shaded flat by a light shining along the camera's line of sight, and painted
// back to front (the painter's algorithm: Canvas 2D has no depth buffer), each
// triangle ranked by its farthest corner: a small part lying on a large face (a bolt
// on a plate) then comes after the face, where ranking by centres puts a large face
// over whatever it carries. A flat face is one colour; runs of triangles of one
// colour are filled as one path, which saves fills and leaves no hairline seams
// between them where antialiasing would show the background.

const SHADES = 24; // brightness steps: each colour has at most this many fill styles
const AMBIENT = 0.38; // a face seen edge-on keeps this share of its colour
const GROW = 4096;
const SEAM_PX = 0.75; // width of the outline that closes the seams between shades

const _modelView = new THREE.Matrix4();
const _v = new THREE.Vector3();
const _colour = new THREE.Color();

/**
 * Triangles of one frame: `add()` each mesh, then `paint()` them all, back to front.
 * Buffers grow to the largest frame and are reused.
 */
class Triangles {

	constructor() {

		this.count = 0;
		this._screen = new Float32Array( GROW * 6 ); // x, y of 3 corners, CSS px
		this._depth = new Float32Array( GROW ); // view-space z of the farthest corner (more negative: farther)
		this._style = new Array( GROW ); // fill style
		this._alpha = new Float32Array( GROW );
		this._order = new Uint32Array( GROW );
		this._view = new Float32Array( 0 ); // a mesh's vertices in view space, then on screen
		this._styles = new Map(); // colour (sRGB hex) * SHADES + shade -> CSS colour
		this._byDepth = ( a, b ) => this._depth[ a ] - this._depth[ b ];

	}

	clear() {

		this.count = 0;

	}

	/**
	 * Project a mesh's triangles: `positions` (x, y, z per vertex, in the frame of
	 * `matrixWorld`), `index` (3 per triangle), seen by `camera` on a `width` x `height` px
	 * view; `color` (linear, three's) lit by the camera's lamp unless `unlit`; `cull`: 1
	 * drops triangles facing away (front side only), -1 those facing the camera, 0 none.
	 */
	add( positions, index, matrixWorld, camera, width, height, color, opacity, unlit = false, cull = 1 ) {

		_modelView.multiplyMatrices( camera.matrixWorldInverse, matrixWorld );
		const vertices = positions.length / 3;
		if ( this._view.length < vertices * 5 ) this._view = new Float32Array( vertices * 5 + 3 * GROW );
		const view = this._view; // per vertex: view x, y, z, screen x, y
		const near = - camera.near;
		for ( let i = 0; i < vertices; i ++ ) {

			_v.fromArray( positions, i * 3 ).applyMatrix4( _modelView );
			const at = i * 5;
			view[ at ] = _v.x;
			view[ at + 1 ] = _v.y;
			view[ at + 2 ] = _v.z;
			if ( _v.z > near ) continue; // behind the near plane: its triangles are dropped
			_v.applyMatrix4( camera.projectionMatrix ); // normalised device coordinates
			view[ at + 3 ] = ( _v.x + 1 ) / 2 * width;
			view[ at + 4 ] = ( 1 - _v.y ) / 2 * height;

		}
		const hex = color.getHex();
		for ( let t = 0; t < index.length; t += 3 ) {

			const a = index[ t ] * 5, b = index[ t + 1 ] * 5, c = index[ t + 2 ] * 5;
			if ( view[ a + 2 ] > near || view[ b + 2 ] > near || view[ c + 2 ] > near ) continue;
			const ax = view[ a + 3 ], ay = view[ a + 4 ], bx = view[ b + 3 ], by = view[ b + 4 ], cx = view[ c + 3 ], cy = view[ c + 4 ];
			// Screen-space winding: y grows downwards, so a counter-clockwise (front) face has area < 0.
			const area = ( bx - ax ) * ( cy - ay ) - ( by - ay ) * ( cx - ax );
			if ( cull * area > 0 || area === 0 ) continue;
			if ( ( ax < 0 && bx < 0 && cx < 0 ) || ( ay < 0 && by < 0 && cy < 0 ) ) continue;
			if ( ( ax > width && bx > width && cx > width ) || ( ay > height && by > height && cy > height ) ) continue;
			this._grow();
			const n = this.count ++;
			const s = this._screen;
			s[ n * 6 ] = ax; s[ n * 6 + 1 ] = ay; s[ n * 6 + 2 ] = bx; s[ n * 6 + 3 ] = by; s[ n * 6 + 4 ] = cx; s[ n * 6 + 5 ] = cy;
			this._depth[ n ] = Math.min( view[ a + 2 ], view[ b + 2 ], view[ c + 2 ] );
			this._alpha[ n ] = opacity;
			this._style[ n ] = this._fill( hex, color, unlit ? 1 : this._light( view, a, b, c ) );

		}

	}

	// Lambert light shining along the camera's axis (view space: -z): the cosine is the
	// face normal's z, the same for every triangle of a flat face.
	_light( view, a, b, c ) {

		const ux = view[ b ] - view[ a ], uy = view[ b + 1 ] - view[ a + 1 ], uz = view[ b + 2 ] - view[ a + 2 ];
		const wx = view[ c ] - view[ a ], wy = view[ c + 1 ] - view[ a + 1 ], wz = view[ c + 2 ] - view[ a + 2 ];
		const nx = uy * wz - uz * wy, ny = uz * wx - ux * wz, nz = ux * wy - uy * wx;
		const cos = Math.abs( nz ) / ( Math.hypot( nx, ny, nz ) || 1 );
		return AMBIENT + ( 1 - AMBIENT ) * cos;

	}

	// One CSS colour per colour and brightness step, made once: shaded in linear light,
	// written in sRGB (as three's renderer outputs it).
	_fill( hex, color, brightness ) {

		const shade = Math.round( brightness * ( SHADES - 1 ) );
		const key = hex * SHADES + shade;
		let style = this._styles.get( key );
		if ( style === undefined ) {

			style = _colour.copy( color ).multiplyScalar( shade / ( SHADES - 1 ) ).getStyle();
			this._styles.set( key, style );

		}
		return style;

	}

	_grow() {

		if ( this.count < this._depth.length ) return;
		const size = this._depth.length + GROW;
		const screen = new Float32Array( size * 6 );
		screen.set( this._screen );
		this._screen = screen;
		for ( const name of [ '_depth', '_alpha' ] ) {

			const more = new Float32Array( size );
			more.set( this[ name ] );
			this[ name ] = more;

		}
		this._style.length = size;
		this._order = new Uint32Array( size );

	}

	/** Fill every triangle added, farthest first; returns the number of fills. */
	paint( ctx ) {

		const n = this.count;
		const order = this._order.subarray( 0, n );
		for ( let i = 0; i < n; i ++ ) order[ i ] = i;
		order.sort( this._byDepth );
		const s = this._screen;
		let fills = 0;
		let style = null;
		let alpha = - 1;
		const width = ctx.lineWidth;
		ctx.lineWidth = SEAM_PX;
		ctx.lineJoin = 'round';
		for ( let k = 0; k < n; k ++ ) {

			const i = order[ k ];
			if ( this._style[ i ] !== style || this._alpha[ i ] !== alpha ) {

				if ( style !== null ) fills += this._fillPath( ctx, alpha );
				style = this._style[ i ];
				if ( this._alpha[ i ] !== alpha ) ctx.globalAlpha = alpha = this._alpha[ i ];
				ctx.fillStyle = style;
				ctx.strokeStyle = style;
				ctx.beginPath();

			}
			const at = i * 6;
			ctx.moveTo( s[ at ], s[ at + 1 ] );
			ctx.lineTo( s[ at + 2 ], s[ at + 3 ] );
			ctx.lineTo( s[ at + 4 ], s[ at + 5 ] );
			ctx.closePath();

		}
		if ( style !== null ) fills += this._fillPath( ctx, alpha );
		ctx.globalAlpha = 1;
		ctx.lineWidth = width;
		ctx.lineJoin = 'miter';
		return fills;

	}

	// Fill the path; an opaque one is also outlined in its colour, thinly: where two
	// shades meet, the antialiased edges of both would let the background through in a
	// hairline. A translucent one is not (its outline would show twice as dense).
	_fillPath( ctx, alpha ) {

		ctx.fill();
		if ( alpha < 1 ) return 1;
		ctx.stroke();
		return 2;

	}

}

export { Triangles };
