import * as THREE from 'three';

// The 2D view's lines: the floor grid, world axes, TCP trails, the clearance boxes,
// the markers' axes. Each segment is cut where it passes behind the camera's near
// plane (the grid runs under the camera), projected with the camera's matrices, and
// stroked with the segments of the same colour in one path.

const _modelView = new THREE.Matrix4();
const _a = new THREE.Vector3();
const _b = new THREE.Vector3();
const _colour = new THREE.Color();

/** CSS colour of a segment (vertex colours): its first vertex's. */
function vertexStyle( colors, i ) {

	return _colour.fromBufferAttribute( colors, i ).getStyle();

}

/**
 * Stroke `line` (a THREE.Line or LineSegments, its draw range and index honoured) as
 * `camera` sees it on a `width` x `height` px view; returns the segments drawn.
 */
function strokeLine( ctx, line, camera, width, height ) {

	const geometry = line.geometry;
	const position = geometry.attributes.position;
	if ( ! position ) return 0;
	const material = Array.isArray( line.material ) ? line.material[ 0 ] : line.material;
	const colors = material.vertexColors ? geometry.attributes.color : null;
	const index = geometry.index;
	const total = index ? index.count : position.count;
	const start = Math.max( 0, geometry.drawRange.start );
	const end = Math.min( total, start + geometry.drawRange.count );
	const step = line.isLineSegments ? 2 : 1;
	_modelView.multiplyMatrices( camera.matrixWorldInverse, line.matrixWorld );
	const paths = new Map(); // CSS colour -> [x0, y0, x1, y1, ...]
	const own = colors ? null : material.color.getStyle();
	const near = - camera.near;
	let drawn = 0;
	for ( let k = start; k + 1 < end; k += step ) {

		const i = index ? index.getX( k ) : k;
		const j = index ? index.getX( k + 1 ) : k + 1;
		_a.fromBufferAttribute( position, i ).applyMatrix4( _modelView );
		_b.fromBufferAttribute( position, j ).applyMatrix4( _modelView );
		if ( _a.z > near && _b.z > near ) continue;
		// Cut at the near plane: what lies behind it has no place on screen.
		if ( _a.z > near ) _a.lerp( _b, ( _a.z - near ) / ( _a.z - _b.z ) );
		else if ( _b.z > near ) _b.lerp( _a, ( _b.z - near ) / ( _b.z - _a.z ) );
		_a.applyMatrix4( camera.projectionMatrix );
		_b.applyMatrix4( camera.projectionMatrix );
		const style = own ?? vertexStyle( colors, i );
		let path = paths.get( style );
		if ( path === undefined ) paths.set( style, path = [] );
		path.push( ( _a.x + 1 ) / 2 * width, ( 1 - _a.y ) / 2 * height, ( _b.x + 1 ) / 2 * width, ( 1 - _b.y ) / 2 * height );
		drawn ++;

	}
	ctx.globalAlpha = material.transparent ? material.opacity : 1;
	for ( const [ style, path ] of paths ) {

		ctx.strokeStyle = style;
		ctx.beginPath();
		for ( let p = 0; p < path.length; p += 4 ) {

			ctx.moveTo( path[ p ], path[ p + 1 ] );
			ctx.lineTo( path[ p + 2 ], path[ p + 3 ] );

		}
		ctx.stroke();

	}
	ctx.globalAlpha = 1;
	return drawn;

}

export { strokeLine };
